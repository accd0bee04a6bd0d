"""Restoration-model data: the pairs of a built ``unicac dataset`` folder (:class:`DatasetFolder`),
and (degraded, sharp) training pairs generated on the fly (:class:`PairGenerator`).

:class:`DatasetFolder` reads a folder written by ``unicac dataset build`` (layout in the repository's
``docs/dataset.md``): its manifests, and each pair's LQ/GT images as float32 H x W x 3 sRGB in [0, 1]
with the model inputs of docs/models.md for any window of the pair: the FoV map (float32 [2, h, w]),
the PSF-feature map (float32 [15, h, w]), the PSF code (float32 [50, h, w], in the dataset's PSF basis)
and the field-varying Wiener estimate (float32 h x w x 3), all computed by the one Rust implementation
(``unicac.fov_map``, ``unicac.psf_features``, ``unicac.psf_code_map``, ``unicac.wiener_restore``).
:func:`folder_torch_dataset` wraps it for PyTorch.

:class:`PairGenerator` is the numpy core: every pair is a pure function of ``(seed, index)``, so a
run is reproducible and data-loader workers can share the work without coordination
(:meth:`PairGenerator.iter_pairs` gives worker ``w`` of ``n`` the indices ``w, w + n, w + 2n, ...``).
:func:`torch_dataset` wraps it as a PyTorch dataset; torch is imported only when that function is
called (install it with ``pip install "unicac[train]"``).

One pair: pick a lens, a sharp frame (a random crop of an image from ``images``, or a generated
chart) and a random patch of it, and simulate the patch through the lens on the sensor (spatially
varying PSFs, distortion, relative illumination, noise, ISP; ``Simulator.render_pair_window``, which
renders only the patch and the margin its pixels depend on; the traced PSFs of each lens are kept per
process). The target is the sharp patch through the same output encoding. Patches
are float32 H x W x 3, sRGB-encoded, in [0, 1]. Optional optical priors: the field map of the patch
(sensor x and y divided by the half-diagonal, and the field angle in degrees) and the PSFs at the
patch centre.
"""

from __future__ import annotations

import os
from collections import OrderedDict
from pathlib import Path
from typing import Any, Iterator, Optional, Sequence, Union

import numpy as np

from . import _native

IMAGE_SUFFIXES = (".png", ".tif", ".tiff", ".exr")
CHART_KINDS = ("dead-leaves", "checkerboard", "slanted-edge", "siemens-star")
# What a pair asks a model to undo (as `unicac dataset build --task`; docs/dataset.md).
PAIR_TASKS = ("aligned", "full")
_SEED_BOUND = 2**63

LensLike = Union[str, "os.PathLike[str]", _native.Lens]


def _lens_source(lens: LensLike) -> str:
    """What ``load_lens`` needs to rebuild a lens in another process (Lens objects do not pickle)."""
    if isinstance(lens, _native.Lens):
        return lens.source
    return os.fspath(lens)


class PairGenerator:
    """Deterministic (degraded, sharp) patch pairs from sharp images and lenses.

    Args:
        lenses: lenses as ``Lens`` objects, paths (``.json``/``.zmx``) or ``"builtin:NAME"``.
        images: a folder of sharp images (PNG, TIFF, EXR; searched recursively), a list of files, or
            None to use generated charts (``charts``). Images must be at least ``frame_px`` large.
        patch_px: side of the square patches.
        frame_px: (width, height) of the sensor frame each pair is simulated on; the patch is cut
            from a random place in it, so patches cover the whole field of the lens.
        seed: base seed; pair ``index`` depends on ``(seed, index)`` only.
        charts: chart kinds drawn from when ``images`` is None.
        isp, noise: switches of the sensor/ISP chain (as ``unicac simulate --no-isp/--no-noise``).
        task: what a pair asks a model to undo, as ``unicac dataset build --task``: ``"aligned"`` (the
            default) renders the patch without the lens's distortion warp and shading, so degraded and
            target differ by blur and noise only (a built dataset's aligned pairs carry the warp and the
            shading in both; here they are left out of both, which aligns the pixels alike);
            ``"full"`` warps and shades the degraded patch only (the target is the undistorted,
            unshaded scene: the model must also undistort and de-shade).
        pixel_um: sensor pixel pitch; None makes each lens's field fill the frame's half-diagonal.
        with_field_map: add ``"field_map"`` (float32 P x P x 3: x / half-diagonal, y / half-diagonal,
            field angle in degrees) to each pair.
        with_psf: add ``"psf"`` (float32 3 x K x K, the R, G, B PSFs at the patch centre).
        psf_px: give every ``"psf"`` this odd side K (centre-cropped or zero-padded, renormalised),
            so that pairs from lenses with different kernel sizes batch together; None keeps each
            lens's own size.
        cache_size: simulators (traced PSF maps) kept per process, least recently used dropped.
    """

    def __init__(
        self,
        lenses: Sequence[LensLike],
        images: Union[None, str, "os.PathLike[str]", Sequence[Union[str, "os.PathLike[str]"]]] = None,
        *,
        patch_px: int = 128,
        frame_px: tuple[int, int] = (512, 384),
        seed: int = 0,
        charts: Sequence[str] = ("dead-leaves",),
        isp: bool = True,
        noise: bool = True,
        task: str = "aligned",
        pixel_um: Optional[float] = None,
        with_field_map: bool = False,
        with_psf: bool = False,
        psf_px: Optional[int] = None,
        cache_size: int = 4,
    ) -> None:
        if len(lenses) == 0:
            raise ValueError("lenses: give at least one lens")
        width, height = (int(v) for v in frame_px)
        if not (0 < patch_px <= min(width, height)):
            raise ValueError(f"patch_px: {patch_px} must be positive and fit in frame_px {frame_px}")
        if psf_px is not None and (psf_px < 1 or psf_px % 2 == 0):
            raise ValueError(f"psf_px: {psf_px} must be a positive odd number")
        if task not in PAIR_TASKS:
            raise ValueError(f"task: '{task}' is not one of {PAIR_TASKS}")
        if images is None and not charts:
            raise ValueError("charts: give at least one chart kind when images is None")
        for kind in charts:
            if kind not in CHART_KINDS:
                raise ValueError(f"charts: '{kind}' is not one of {CHART_KINDS}")
        self.lens_sources = [_lens_source(lens) for lens in lenses]
        self.image_paths = _image_paths(images) if images is not None else []
        if images is not None and not self.image_paths:
            raise ValueError(f"images: no {'/'.join(IMAGE_SUFFIXES)} files found in {images!r}")
        self.patch_px = int(patch_px)
        self.frame_px = (width, height)
        self.seed = int(seed)
        self.charts = tuple(charts)
        self.isp = bool(isp)
        self.noise = bool(noise)
        self.task = task
        self.pixel_um = pixel_um
        self.with_field_map = bool(with_field_map)
        self.with_psf = bool(with_psf)
        self.psf_px = psf_px
        self.cache_size = max(1, int(cache_size))
        self._simulators: OrderedDict[int, tuple[_native.Simulator, Optional[np.ndarray]]] = OrderedDict()
        # Fail early (in the parent process) on a lens that does not load.
        for source in self.lens_sources:
            _native.load_lens(source)

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state["_simulators"] = OrderedDict()  # rebuilt lazily in each worker process
        return state

    def _simulator(self, lens_index: int) -> tuple[_native.Simulator, Optional[np.ndarray]]:
        cached = self._simulators.get(lens_index)
        if cached is not None:
            self._simulators.move_to_end(lens_index)
            return cached
        lens = _native.load_lens(self.lens_sources[lens_index])
        width, height = self.frame_px
        geometry = self.task == "full"  # aligned: neither the warp nor the shading, in either image
        simulator = _native.Simulator(lens, width, height, pixel_um=self.pixel_um, distortion=geometry,
                                      illumination=geometry)
        field_map = None
        if self.with_field_map:
            field_map = simulator.field_map()
            field_map[..., :2] /= np.float32(simulator.half_diagonal_mm)
        self._simulators[lens_index] = (simulator, field_map)
        while len(self._simulators) > self.cache_size:
            self._simulators.popitem(last=False)
        return simulator, field_map

    def _sharp_frame(self, rng: np.random.Generator) -> np.ndarray:
        width, height = self.frame_px
        if not self.image_paths:
            kind = self.charts[int(rng.integers(len(self.charts)))]
            return _native.chart(kind, width, height, seed=int(rng.integers(_SEED_BOUND)))
        path = self.image_paths[int(rng.integers(len(self.image_paths)))]
        image = _native.read_image(path, linear=True)
        h, w = image.shape[:2]
        if h < height or w < width:
            raise ValueError(f"{path}: {w} x {h} px is smaller than frame_px {self.frame_px}")
        y0 = int(rng.integers(h - height + 1))
        x0 = int(rng.integers(w - width + 1))
        return np.ascontiguousarray(image[y0 : y0 + height, x0 : x0 + width])

    def pair(self, index: int) -> dict[str, Any]:
        """The pair number ``index``: a dict with ``degraded`` and ``sharp`` (float32 P x P x 3),
        ``lens`` (its source), ``origin_px`` (column, row of the patch in the frame) and, if asked,
        ``field_map`` and ``psf``. A pure function of ``(seed, index)``."""
        if index < 0:
            raise ValueError(f"index: {index} must be non-negative")
        rng = np.random.default_rng([self.seed, int(index)])
        lens_index = int(rng.integers(len(self.lens_sources)))
        frame = self._sharp_frame(rng)
        simulator, field_map = self._simulator(lens_index)
        seed = int(rng.integers(_SEED_BOUND))
        width, height = self.frame_px
        p = self.patch_px
        y0 = int(rng.integers(height - p + 1))
        x0 = int(rng.integers(width - p + 1))
        window = (slice(y0, y0 + p), slice(x0, x0 + p))
        # Only the patch and the margin its pixels depend on (PSF, distortion) are rendered.
        degraded, sharp = simulator.render_pair_window(frame, x0, y0, p, p, seed=seed, isp=self.isp, noise=self.noise)
        out: dict[str, Any] = {
            "degraded": degraded,
            "sharp": sharp,
            "lens": self.lens_sources[lens_index],
            "index": int(index),
            "origin_px": (x0, y0),
        }
        if field_map is not None:
            out["field_map"] = np.ascontiguousarray(field_map[window])
        if self.with_psf:
            psf = simulator.psf_at(x0 + (p - 1) / 2, y0 + (p - 1) / 2)
            out["psf"] = psf if self.psf_px is None else fit_kernels(psf, self.psf_px)
        return out

    def iter_pairs(
        self, worker: int = 0, num_workers: int = 1, start: int = 0, stop: Optional[int] = None
    ) -> Iterator[dict[str, Any]]:
        """Pairs ``start + worker``, ``start + worker + num_workers``, ... (up to ``stop``, or
        forever): the share of one of ``num_workers`` workers. Deterministic per seed and worker; the
        union over the workers is the same sequence whatever their number."""
        if not (0 <= worker < num_workers):
            raise ValueError(f"worker: {worker} must lie in [0, num_workers={num_workers})")
        index = start + worker
        while stop is None or index < stop:
            yield self.pair(index)
            index += num_workers


def _image_paths(images: Union[str, "os.PathLike[str]", Sequence[Union[str, "os.PathLike[str]"]]]) -> list[str]:
    if isinstance(images, (str, os.PathLike)):
        root = Path(images)
        if not root.is_dir():
            raise ValueError(f"images: {root} is not a folder")
        files = (p for p in root.rglob("*") if p.suffix.lower() in IMAGE_SUFFIXES and p.is_file())
        return sorted(str(p) for p in files)
    return [os.fspath(p) for p in images]


def fit_kernels(kernels: np.ndarray, size: int) -> np.ndarray:
    """(C, K, K) kernels centre-cropped or zero-padded to (C, size, size), each renormalised to sum 1."""
    k = kernels.shape[-1]
    if size < k:
        start = (k - size) // 2
        fitted = kernels[:, start : start + size, start : start + size]
    else:
        pad = (size - k) // 2
        fitted = np.pad(kernels, ((0, 0), (pad, pad), (pad, pad)))
    sums = fitted.sum(axis=(1, 2), keepdims=True)
    return np.ascontiguousarray(fitted / np.where(sums > 0, sums, 1), dtype=np.float32)


def to_chw(image: np.ndarray) -> np.ndarray:
    """H x W x C -> C x H x W (contiguous), the layout of PyTorch tensors."""
    return np.ascontiguousarray(np.moveaxis(image, -1, 0))


def torch_dataset(generator: PairGenerator, length: Optional[int] = None) -> Any:
    """A PyTorch dataset over ``generator``. Imports torch (``pip install "unicac[train]"``).

    With ``length``: a map-style ``Dataset`` of pairs ``0..length-1`` (shuffle in the DataLoader).
    Without: an endless ``IterableDataset``; in a DataLoader each worker takes its share of the
    indices (``iter_pairs(worker, num_workers)``), so the stream is deterministic per seed and worker.
    Items are dicts of tensors: ``degraded`` and ``sharp`` (float32 3 x P x P), ``field_map``
    (3 x P x P) and ``psf`` (3 x K x K) when the generator adds them, and ``index``.
    """
    import torch
    from torch.utils.data import Dataset, IterableDataset, get_worker_info

    def tensors(pair: dict[str, Any]) -> dict[str, Any]:
        out = {
            "degraded": torch.from_numpy(to_chw(pair["degraded"])),
            "sharp": torch.from_numpy(to_chw(pair["sharp"])),
            "index": pair["index"],
        }
        if "field_map" in pair:
            out["field_map"] = torch.from_numpy(to_chw(pair["field_map"]))
        if "psf" in pair:
            out["psf"] = torch.from_numpy(np.ascontiguousarray(pair["psf"]))
        return out

    if length is not None:

        class PairDataset(Dataset):  # type: ignore[type-arg]
            def __len__(self) -> int:
                return int(length)

            def __getitem__(self, index: int) -> dict[str, Any]:
                if not (0 <= index < int(length)):
                    raise IndexError(index)
                return tensors(generator.pair(index))

        return PairDataset()

    class PairStream(IterableDataset):  # type: ignore[type-arg]
        def __iter__(self) -> Iterator[dict[str, Any]]:
            info = get_worker_info()
            worker, workers = (0, 1) if info is None else (info.id, info.num_workers)
            return (tensors(pair) for pair in generator.iter_pairs(worker, workers))

    return PairStream()


# ----------------------------------------------------------------------------------------------
# Built datasets (`unicac dataset build`, docs/dataset.md)


#: A PSF basis folder's files (crates/unicac-dataset/src/psf_basis.rs), arrays first: a basis is
#: complete once basis.json exists, so a copy interrupted before it is no basis at all.
BASIS_JSON = "basis.json"
PSF_BASIS_FILES = ("mean.npy", "components.npy", BASIS_JSON)


def dataset_basis_dir(root: "os.PathLike[str] | str") -> Path:
    """Where a dataset folder keeps its PSF basis (Rust's `BASIS_RELATIVE`)."""
    return Path(root) / "psf" / "basis"


def basis_sha256(folder: "os.PathLike[str] | str") -> Optional[str]:
    """The ``sha256`` a PSF basis folder's basis.json records, or None when it has none. (The arrays
    are checked against it by every reader of the basis: `unicac dataset build --psf-basis-from`,
    `unicac bench`.)"""
    import json

    path = Path(folder) / BASIS_JSON
    try:
        return str(json.loads(path.read_text())["sha256"])
    except (OSError, ValueError, KeyError, TypeError):
        return None


def copy_psf_basis(source: "os.PathLike[str] | str", target: "os.PathLike[str] | str") -> str:
    """Copies the PSF basis folder ``source`` to ``target`` (each file atomically, basis.json last);
    returns its ``sha256``. A psf_code model reads its input in this basis, so the basis travels with
    the run and with the exported model (``NAME.basis/`` beside ``NAME.onnx``)."""
    from .outputs import copy_file

    source, target = Path(source), Path(target)
    sha = basis_sha256(source)
    if sha is None or not all((source / name).is_file() for name in PSF_BASIS_FILES):
        raise DatasetFolderError(f"{source}: not a complete PSF basis folder ({', '.join(PSF_BASIS_FILES)})")
    for name in PSF_BASIS_FILES:
        copy_file(source / name, target / name)
    return sha


class DatasetFolderError(_native.DatasetError, ValueError):
    """A folder that is not a readable unicac dataset, or a request it cannot serve (the message names
    the folder or file and what is missing). A :class:`unicac.DatasetError` (what Rust's reader raises)
    and, for callers that catch argument errors, a ``ValueError``."""


def _rust(call: Any, *args: Any) -> Any:
    """A call into the dataset reader, its ``DatasetError`` raised as :class:`DatasetFolderError`."""
    try:
        return call(*args)
    except _native.DatasetError as error:
        raise DatasetFolderError(str(error)) from None


def _image_float(path: Path) -> np.ndarray:
    """A dataset PNG as float32 H x W x 3, sRGB-encoded, in [0, 1] (the codes divided by their maximum)."""
    codes = _native.read_image(path)
    if codes.dtype == np.uint8:
        return codes.astype(np.float32) / np.float32(255)
    if codes.dtype == np.uint16:
        return codes.astype(np.float32) / np.float32(65535)
    raise DatasetFolderError(f"{path}: expected an 8- or 16-bit sRGB image, got {codes.dtype}")


class DatasetFolder:
    """A built dataset folder, read as numpy.

    Args:
        root: the folder given to ``unicac dataset build --out``.

    Raises :class:`DatasetFolderError` when ``root`` holds no ``dataset.json`` of the unicac format
    (naming the folder as not a unicac dataset), when the format is newer than this reader, and when
    a pair's ``gt`` and ``lq`` are the same file or the same pixels (a GT folder pointed at the
    degraded one).
    """

    def __init__(self, root: Union[str, "os.PathLike[str]"]) -> None:
        self.root = Path(root)
        if not self.root.is_dir():
            what = "not a folder" if self.root.exists() else "no such folder"
            raise DatasetFolderError(f"{self.root}: {what} (expected a unicac dataset folder)")
        # The one reader (Rust's, as `unicac bench` reads): dataset.json's format and version, every
        # row's fields and types, and the rows against dataset.json's counts.
        read = _rust(_native.read_dataset, self.root)
        self.manifest: dict[str, Any] = read["manifest"]
        self._pairs: list[dict[str, Any]] = read["pairs"]
        self._lenses: list[dict[str, Any]] = read["lenses"]
        self._field_codes: dict[str, tuple[Any, Any]] = {}

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state["_field_codes"] = {}  # recomputed lazily in each worker process
        return state

    @property
    def psf_basis_dir(self) -> Path:
        return dataset_basis_dir(self.root)

    def psf_basis(self) -> dict[str, Any]:
        """The dataset's PSF basis (``psf/basis/basis.json``: components, explained shares, ``sha256``);
        :class:`DatasetFolderError` saying how to make it when the folder has none."""
        path = self.psf_basis_dir / BASIS_JSON
        if not path.is_file():
            raise DatasetFolderError(
                f"{self.root}: no PSF basis ({path} is missing; models with the `psf_code` input need it): run the "
                "same `unicac dataset build` command again (it resumes the finished dataset and fits the basis), or "
                f"python -c 'import unicac; unicac.psf_basis(\"{self.root}\")'"
            )
        return _rust(_native.psf_basis, self.root)

    def largest_kernel_px(self, split: str) -> Optional[int]:
        """The widest PSF kernel (``kernel_px`` of ``table.json``) among the lenses of ``split`` that have
        a PSF table, or None when none has."""
        sizes = [self._table_meta(table)["kernel_px"]
                 for table in sorted({row["psf"] for row in self.pairs(split) if row.get("psf")})
                 if (self.path(table) / "table.json").is_file()]
        return max(sizes) if sizes else None

    def _table_meta(self, table: str) -> dict[str, Any]:
        return _rust(_native.psf_table_meta, self.path(table))

    def pair_checks(self, split: str) -> dict[str, dict[str, Any]]:
        """The pairs' recorded checks (docs/dataset.md, "Pair checks") averaged per lens of ``split``:
        lens_id -> {pairs, checked, mean_lq_gt_psnr_db, mean_registration_px, mean_blur_share, flag}
        (and the lens's split, level and ode), as ``unicac dataset info`` prints them. ``flag`` says why a
        lens's pairs are dominated by something other than blur (a mean shift above 0.5 px or a blur
        share below 50%); the means are None for a dataset built before pairs carried checks."""
        checks = _rust(_native.dataset_pair_checks, self.root, split)
        return {row.pop("lens_id"): row for row in checks}

    @property
    def ode_levels(self) -> int:
        """How many ODE test levels the dataset has (0: none)."""
        return max(len(self._ode_thresholds()) - 1, 0)

    def _ode_thresholds(self) -> list[float]:
        stratification = next((s for s in self.manifest.get("stratifications", []) if s.get("metric") == "ode"), None)
        return list((stratification or {}).get("thresholds") or [])

    def ode_level(self, ode: float) -> Optional[int]:
        """The test level (1 = mildest) whose ODE range holds ``ode``, by ``dataset.json``'s ODE
        thresholds (docs/dataset.md: level k holds [thresholds[k], thresholds[k-1]]; values beyond the
        extremes go to the end levels), so any lens, not only a test lens, can be placed on the test
        levels' scale; None when the dataset has no ODE levels."""
        thresholds = self._ode_thresholds()
        if len(thresholds) < 2:
            return None
        levels = len(thresholds) - 1
        return next((k for k in range(1, levels + 1) if ode >= thresholds[k]), levels)

    def lenses(self) -> list[dict[str, Any]]:
        """Rows of ``lenses.jsonl`` (lens_id, split, level, ode, ...)."""
        return list(self._lenses)

    def pairs(self, split: Optional[str] = None) -> list[dict[str, Any]]:
        """Rows of ``pairs.jsonl``, in manifest order, optionally of one split."""
        return [row for row in self._pairs if split is None or row.get("split") == split]

    def path(self, relative: str) -> Path:
        """A manifest path resolved against the folder (absolute paths, ``..`` and ``.`` refused)."""
        return Path(_rust(_native.dataset_path, self.root, relative))

    def has_psf(self, row: dict[str, Any]) -> bool:
        """Whether the pair's lens has a PSF table (needed for the ``psf`` input)."""
        table = row.get("psf")
        return bool(table) and (self.path(table) / "table.json").is_file()

    def check_split(self, split: str, need_psf: bool = False) -> list[dict[str, Any]]:
        """The pairs of ``split``, after checking that there are some, that their GT is not their LQ
        and (``need_psf``) that every lens has its PSF table."""
        rows = self.pairs(split)
        if not rows:
            splits = sorted({str(r.get("split")) for r in self._pairs})
            raise DatasetFolderError(f"{self.root}: no '{split}' pairs (splits present: {', '.join(splits) or 'none'})")
        first = rows[0]
        lq, gt = self.path(first["lq"]), self.path(first["gt"])
        if lq.resolve() == gt.resolve() or (lq.is_file() and gt.is_file() and lq.read_bytes() == gt.read_bytes()):
            raise DatasetFolderError(
                f"{self.root}: pair {first['pair_id']}: gt ({first['gt']}) holds the same image as lq ({first['lq']}); "
                "the ground-truth folder points at the degraded images"
            )
        if need_psf:
            missing = sorted({r["lens_id"] for r in rows if not self.has_psf(r)})
            if missing:
                raise DatasetFolderError(
                    f"{self.root}: this model needs PSF maps, but the dataset has no PSF table for lens "
                    f"{', '.join(missing[:5])}{' ...' if len(missing) > 5 else ''} (expected psf/LENS_ID/table.json)"
                )
        return rows

    def load(
        self,
        row: dict[str, Any],
        window: Optional[tuple[int, int, int, int]] = None,
        fov: bool = False,
        psf: bool = False,
        psf_code: bool = False,
        wiener: bool = False,
        wiener_nsr: float = 0.01,
    ) -> dict[str, Any]:
        """One pair: ``lq`` and ``gt`` (float32 h x w x 3, sRGB in [0, 1]) of ``window`` (x, y, w, h
        in the pair's image; None = all of it), and if asked its ``fov`` [2, h, w], ``psf`` [15, h, w]
        and ``psf_code`` [50, h, w] maps and its ``wiener`` estimate (h x w x 3, computed on the window
        grown by one kernel width where the image allows, then cut): the pair's frame position comes
        from its ``crop`` and ``frame_px`` entries, so every frame size and crop is placed correctly
        (nothing assumes one frame size)."""
        lq = _image_float(self.path(row["lq"]))
        gt = _image_float(self.path(row["gt"]))
        if lq.shape != gt.shape:
            raise DatasetFolderError(f"{self.root}: pair {row['pair_id']}: lq is {lq.shape[:2]} px but gt is {gt.shape[:2]} px")
        height, width = lq.shape[:2]
        x, y, w, h = window if window is not None else (0, 0, width, height)
        if not (0 <= x and 0 <= y and w > 0 and h > 0 and x + w <= width and y + h <= height):
            raise ValueError(f"window: {window} does not fit in pair {row['pair_id']} ({width} x {height} px)")
        out: dict[str, Any] = {
            "lq": np.ascontiguousarray(lq[y : y + h, x : x + w]),
            "gt": np.ascontiguousarray(gt[y : y + h, x : x + w]),
            "pair_id": row["pair_id"],
            "lens_id": row.get("lens_id"),
        }
        frame_w, frame_h = (int(v) for v in row["frame_px"])
        cx, cy, cw, ch = (int(v) for v in row["crop"])
        if (cw, ch) != (width, height):
            raise DatasetFolderError(
                f"{self.root}: pair {row['pair_id']}: its image is {width} x {height} px but its crop entry says {cw} x {ch}"
            )
        if fov:
            out["fov"] = _native.fov_map(frame_w, frame_h, cx + x, cy + y, w, h)
        if (psf or psf_code or wiener) and not self.has_psf(row):
            raise DatasetFolderError(f"{self.root}: pair {row['pair_id']}: lens {row.get('lens_id')} has no PSF table")
        if psf:
            out["psf"] = _native.psf_features(self.path(row["psf"]), frame_w, frame_h, cx + x, cy + y, w, h)
        if psf_code:
            radii, codes = self._codes(row)
            out["psf_code"] = _native.psf_code_map(radii, codes, frame_w, frame_h, cx + x, cy + y, w, h)
        if wiener:
            out["wiener"] = self._wiener(row, lq, (x, y, w, h), (frame_w, frame_h), (cx, cy), wiener_nsr)
        return out

    def _codes(self, row: dict[str, Any]) -> tuple[Any, Any]:
        table = row["psf"]
        if table not in self._field_codes:
            self.psf_basis()  # a clear error when there is none
            self._field_codes[table] = _native.psf_field_codes(self.path(table), self.psf_basis_dir)
        return self._field_codes[table]

    def _wiener(self, row: dict[str, Any], lq: np.ndarray, window: tuple[int, int, int, int],
                frame: tuple[int, int], crop_origin: tuple[int, int], nsr: float) -> np.ndarray:
        """The Wiener estimate of ``window``: computed on the window grown by one kernel width (the
        context a whole-image estimate has there), then cut to the window."""
        table = self.path(row["psf"])
        margin = int(self._table_meta(row["psf"])["kernel_px"])
        x, y, w, h = window
        height, width = lq.shape[:2]
        x0, y0 = max(0, x - margin), max(0, y - margin)
        x1, y1 = min(width, x + w + margin), min(height, y + h + margin)
        grown = np.ascontiguousarray(lq[y0:y1, x0:x1])
        estimate = _native.wiener_restore(grown, table, frame[0], frame[1], crop_origin[0] + x0, crop_origin[1] + y0, nsr)
        return np.ascontiguousarray(estimate[y - y0 : y - y0 + h, x - x0 : x - x0 + w])


def folder_torch_dataset(
    folder: Union[DatasetFolder, str, "os.PathLike[str]"],
    split: str,
    fov: bool = False,
    psf: bool = False,
) -> Any:
    """A map-style PyTorch ``Dataset`` over one split of a built dataset (whole pairs). Items are dicts
    of tensors: ``lq``, ``gt`` (float32 3 x H x W), and ``fov`` / ``psf`` when asked, plus ``pair_id``.
    Imports torch (``pip install "unicac[train]"``). For training patches with augmentation see
    ``unicac.train.data``."""
    import torch
    from torch.utils.data import Dataset

    folder = folder if isinstance(folder, DatasetFolder) else DatasetFolder(folder)
    rows = folder.check_split(split, need_psf=psf)

    class PairFolderDataset(Dataset):  # type: ignore[type-arg]
        def __len__(self) -> int:
            return len(rows)

        def __getitem__(self, index: int) -> dict[str, Any]:
            pair = folder.load(rows[index], fov=fov, psf=psf)
            item = {
                "lq": torch.from_numpy(to_chw(pair["lq"])),
                "gt": torch.from_numpy(to_chw(pair["gt"])),
                "pair_id": pair["pair_id"],
            }
            for key in ("fov", "psf"):
                if key in pair:
                    item[key] = torch.from_numpy(pair[key])
            return item

    return PairFolderDataset()
