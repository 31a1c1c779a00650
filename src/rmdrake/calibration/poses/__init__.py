"""Poses: 6-DoF tool measurements (a laser tracker with a 6-DoF probe, a
calibrated camera seeing a marker on the tool). The readings and their file,
their simulation, their checks, the residual problem with the unknown
instrument pose X_IB and marker pose X_FM (hand-eye), the LM estimator and the
cross-validated choice of parameters."""
