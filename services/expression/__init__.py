"""The expression service: the facial expression of each fit, from the fit and its frame
(:mod:`services.expression.service`)."""
