"""Kinematic calibration from a ball seated in fixed sockets (MUKCa): the
file format, the residuals and metrics, the estimator, and simulated data."""
