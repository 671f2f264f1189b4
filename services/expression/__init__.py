"""The expression service: the facial expression of each good fit
(:mod:`services.expression.service`)."""
