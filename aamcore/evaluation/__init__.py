"""Measuring fits: metrics (thesis section 7.3 and today's NME), evaluation runs, plots."""
