"""What the studies and ``validate --plot`` show: matplotlib figures
(:mod:`~rmdrake.report.plots`) and pose accuracy in the manner of ISO 9283
(:mod:`~rmdrake.report.iso9283`)."""
