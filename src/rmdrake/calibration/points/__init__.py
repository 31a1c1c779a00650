"""Points: tool positions measured by a laser tracker or motion capture. The
readings and their file, their simulation, their checks, the residual problem
with the instrument's unknown pose, the LM estimator and the cross-validated
choice of parameters."""
