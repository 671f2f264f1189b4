"""The head-pose service: POSIT on each fit (:mod:`services.pose.service`)."""
