"""Comparison tool of the IQ-MPM validation harness.

Reads IQ-MPM and OpenFOAM run folders and the experimental reference data, computes the
errors defined in ``docs/benchmarks.md`` ("What error means") and writes
Markdown reports with PNG plots. Entry point: ``compare/compare`` or ``python3 -m compare``.
"""

from __future__ import annotations

__version__ = "0.1.0"

from compare.io import CompareError

__all__ = ["CompareError", "__version__"]
