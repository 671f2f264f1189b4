"""The head-pose service: the head pose of each fit (:mod:`services.pose.service`)."""
