"""The face detector service: Haar detection on request (a Zenoh queryable) and at a low
rate while no face is tracked (:mod:`services.detector.service`)."""
