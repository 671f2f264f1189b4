"""Training what the fitting algorithms learn: update matrices and descent cascades."""
