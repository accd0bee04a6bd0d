"""The exceptions unicac raises, all subclasses of :class:`UnicacError`.

They are defined by the native module (the one place where Rust errors are mapped, in
``crates/unicac-py/src/errors.rs``) and re-exported here:

==================  =====================================================================
exception           raised when
==================  =====================================================================
LensError           a lens file cannot be read, or is not a valid lens, or its paraxial
                    analysis fails (also when found while tracing, simulating, ...)
TraceError          a trace request fails as a whole (e.g. real ray aiming)
PsfError            a PSF cannot be computed (e.g. the field is vignetted away)
ImageError          an image cannot be read, written or processed (ISP steps)
SimulationError     an image simulation request is invalid (e.g. PSF larger than the image)
MetricsError        a metric cannot be computed from its inputs
OdeError            the Optical Degradation Evaluator fails for a lens
DatasetError        a dataset folder, manifest or PSF table cannot be read or written
OutputError         an output path is refused by the output-file policy (``unicac.outputs``):
                    it is an input, lies inside an input folder, is another output's path,
                    or its extension does not name the format written
==================  =====================================================================

Arguments of the wrong type, dtype or shape raise the built-in ``TypeError`` / ``ValueError``
naming the argument, before any computation. Per-ray failures are not exceptions: they are status
codes (``unicac.STATUS_NAMES``).
"""

from ._native import (
    DatasetError,
    ImageError,
    LensError,
    MetricsError,
    OdeError,
    OutputError,
    PsfError,
    SimulationError,
    TraceError,
    UnicacError,
)

__all__ = [
    "DatasetError",
    "ImageError",
    "LensError",
    "MetricsError",
    "OdeError",
    "OutputError",
    "PsfError",
    "SimulationError",
    "TraceError",
    "UnicacError",
]
