"""The face detector service: Haar detection on request, a Zenoh queryable
(:mod:`services.detector.service`)."""
