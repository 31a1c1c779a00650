"""Plates: a range finder on the tool reads a flat plate put at unknown places
(the paper's measurement). The readings and their file, their simulation, their
checks, the plane-constraint costs (tetrahedron volumes, signed distances), the
estimators, the cross-validated choice of parameters over the plates, the
D-optimal pose choice and the range finder's validity rule."""
