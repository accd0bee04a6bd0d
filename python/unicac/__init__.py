"""unicac: lens tracing, PSFs, image simulation and the Optical Degradation Evaluator from Python.

A thin layer over the native module ``unicac._native`` (Rust, PyO3). Conventions:

* lengths in millimetres, wavelengths in micrometres, angles in degrees, as the argument names say
  (``_mm``, ``_um``, ``_deg``); coordinates as in the repository's ``docs/conventions.md``;
* arrays are numpy arrays with exact dtypes (no silent conversion): rays are float64 (N, 3), images
  H x W x 3 as uint8/uint16 (sRGB codes) or float32 (linear light), PSF kernels float32;
* a wrong dtype raises ``TypeError``, a wrong shape ``ValueError``, both naming the argument; a failed
  request raises a subclass of ``UnicacError`` (``LensError``, ``TraceError``, ...);
* every call that traces or renders releases the GIL, so threads (and data-loader workers) run in
  parallel;
* files are written by the output-file policy of the Rust commands (``unicac.outputs``): an output
  is never an input, extensions name the format, writes are atomic.
"""

from __future__ import annotations

from . import _native
from ._native import (
    Lens,
    Psf,
    Simulator,
    aim_rays,
    apply_white_balance,
    apply_white_balance_mosaic,
    builtin_lenses,
    chart,
    check_outputs,
    clean_stale_temporaries,
    dataset_pair_checks,
    dataset_path,
    demosaic,
    fov_map,
    invert_white_balance,
    isp_draw,
    isp_process,
    isp_target,
    isp_unprocess,
    linear_to_srgb,
    load_lens,
    mosaic_rggb,
    ode,
    oiqe_of_psf,
    pair_check_flag,
    perturb_white_balance,
    psf,
    psf_basis,
    psf_code_map,
    psf_features,
    psf_field_codes,
    psf_grid,
    psf_table_meta,
    quantise,
    read_dataset,
    read_image,
    read_out,
    require_extension,
    simulate,
    spots,
    srgb_to_linear,
    subtract_black_level,
    table_edge_pairs,
    trace,
    trace_detailed,
    write_atomically,
    wiener_restore,
    write_image,
)
from .errors import (
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

__version__: str = _native.__version__

#: Ray status names by code: ``STATUS_NAMES[status]`` for the codes ``trace`` returns
#: (0 ok, 1 missed, 2 tir, 3 clipped, 4 no_convergence, 5 invalid_input).
STATUS_NAMES: tuple[str, ...] = tuple(_native.STATUS_NAMES)
#: Status code of a ray that reached the image surface.
STATUS_OK: int = 0

__all__ = [
    "STATUS_NAMES",
    "STATUS_OK",
    "DatasetError",
    "ImageError",
    "Lens",
    "LensError",
    "MetricsError",
    "OdeError",
    "OutputError",
    "Psf",
    "PsfError",
    "SimulationError",
    "Simulator",
    "TraceError",
    "UnicacError",
    "aim_rays",
    "apply_white_balance",
    "apply_white_balance_mosaic",
    "builtin_lenses",
    "chart",
    "check_outputs",
    "clean_stale_temporaries",
    "demosaic",
    "dataset_pair_checks",
    "dataset_path",
    "fov_map",
    "invert_white_balance",
    "isp_draw",
    "isp_process",
    "isp_target",
    "isp_unprocess",
    "linear_to_srgb",
    "load_lens",
    "mosaic_rggb",
    "ode",
    "oiqe_of_psf",
    "pair_check_flag",
    "perturb_white_balance",
    "psf",
    "psf_basis",
    "psf_code_map",
    "psf_features",
    "psf_field_codes",
    "psf_grid",
    "psf_table_meta",
    "quantise",
    "read_dataset",
    "read_image",
    "read_out",
    "require_extension",
    "simulate",
    "spots",
    "srgb_to_linear",
    "subtract_black_level",
    "table_edge_pairs",
    "trace",
    "trace_detailed",
    "write_atomically",
    "wiener_restore",
    "write_image",
]
