"""Finding a face and a first shape: Haar detection and the box-to-shape mapping.

- ``haar``: OpenCV's Haar cascades (thesis section 7.2.1).
- ``mapping``: from a detector's box to a start shape (thesis section 7.2).
"""
