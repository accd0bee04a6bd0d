"""Datasets the trainer draws from.

Training items are addressed by a global sample number `k` (iteration x batch + slot): the pair,
patch position and augmentation of sample k come from `numpy.random.default_rng([seed, k])`, never
from a shared random state, so data-loader workers, process counts and resumption do not change what
a run sees. Validation items are fixed (`max_pairs` pairs spread over the split's lenses, centre crops,
no augmentation, noise drawn from fixed per-index seeds), so validation is deterministic.
"""

from __future__ import annotations

from typing import Any, Iterator, Optional

import numpy as np
import torch
from torch.utils.data import Dataset, Sampler

from unicac import _native
from unicac.dataset import DatasetFolder, DatasetFolderError, PairGenerator, to_chw

from .augment import augment

_SEED_BOUND = 2**63
#: The tensors a sample may carry: images, then the model-input maps (docs/models.md).
KEYS = ("lq", "gt", "wiener", "fov", "psf", "psf_code")
#: Maps that need the lens's PSF table.
TABLE_MAPS = ("psf", "psf_code", "wiener")


class IterationSampler(Sampler):  # type: ignore[type-arg]
    """Yields the global sample numbers of iterations `start_iter` .. `total_iter - 1`, this rank's
    share: iteration i on rank r of `world` takes samples (i * world + r) * batch + 0 .. batch - 1."""

    def __init__(self, start_iter: int, total_iter: int, batch_size: int, rank: int = 0, world: int = 1) -> None:
        self.start_iter, self.total_iter = start_iter, total_iter
        self.batch_size, self.rank, self.world = batch_size, rank, world

    def __iter__(self) -> Iterator[int]:
        for iteration in range(self.start_iter, self.total_iter):
            first = (iteration * self.world + self.rank) * self.batch_size
            yield from range(first, first + self.batch_size)

    def __len__(self) -> int:
        return max(0, self.total_iter - self.start_iter) * self.batch_size


def _epoch_index(seed: int, k: int, count: int) -> int:
    """Pair index of sample k: each epoch of `count` samples is a fresh seeded permutation."""
    epoch, position = divmod(k, count)
    return int(np.random.default_rng([seed, 0x5EED, epoch]).permutation(count)[position])


def spread_over_lenses(rows: list[dict[str, Any]], count: int) -> list[dict[str, Any]]:
    """`count` of `rows`, taken in turn from each lens (every lens's first pair in manifest order, then
    every lens's second, ...): a manifest lists a lens's pairs together, so its first `count` rows would
    be the first few lenses only (2 of a small run's 10 validation lenses, both mild)."""
    by_lens: dict[str, list[dict[str, Any]]] = {}
    for row in rows:
        by_lens.setdefault(str(row.get("lens_id")), []).append(row)
    chosen: list[dict[str, Any]] = []
    for k in range(max((len(pairs) for pairs in by_lens.values()), default=0)):
        for pairs in by_lens.values():
            if len(chosen) == count:
                return chosen
            if k < len(pairs):
                chosen.append(pairs[k])
    return chosen


def severe_pairs(folder: DatasetFolder, rows: list[dict[str, Any]]) -> list[bool]:
    """Per row, whether its lens's ODE falls in the dataset's two most severe test levels (the last
    one alone with fewer than 3 levels), where restoration is hardest and a model refining the Wiener
    estimate trades PSNR against perceptual quality; all False without ODE levels."""
    levels = folder.ode_levels
    if levels == 0:
        return [False] * len(rows)
    first_severe = max(levels - 1, 1) if levels >= 3 else levels
    ode = {lens["lens_id"]: lens.get("ode") for lens in folder.lenses()}
    return [ode.get(row["lens_id"]) is not None and (folder.ode_level(ode[row["lens_id"]]) or 0) >= first_severe
            for row in rows]


def _tensors(sample: dict[str, Any]) -> dict[str, Any]:
    out = {key: torch.from_numpy(np.ascontiguousarray(sample[key])) for key in KEYS if key in sample}
    out["index"] = int(sample.get("index", 0))
    return out


def collate(items: list[dict[str, Any]]) -> dict[str, Any]:
    batch = {key: torch.stack([item[key] for item in items]) for key in KEYS if key in items[0]}
    batch["index"] = torch.tensor([item["index"] for item in items])
    return batch


def _sample(pair: dict[str, Any], index: int) -> dict[str, Any]:
    """A loaded window as C x H x W arrays: the images, the Wiener estimate and the maps asked for."""
    sample = {"lq": to_chw(pair["lq"]), "gt": to_chw(pair["gt"]), "index": index}
    if "wiener" in pair:
        sample["wiener"] = to_chw(pair["wiener"])
    for key in ("fov", "psf", "psf_code"):
        if key in pair:
            sample[key] = pair[key]
    return sample


def _load_flags(maps: "set[str] | list[str] | tuple[str, ...]", options: dict[str, Any]) -> dict[str, Any]:
    return {"fov": "fov" in maps, "psf": "psf" in maps, "psf_code": "psf_code" in maps, "wiener": "wiener" in maps,
            "wiener_nsr": options["wiener_nsr"]}


class FolderPatches(Dataset):  # type: ignore[type-arg]
    """Random patches of a built dataset's pairs (sample number k -> one augmented patch)."""

    def __init__(self, folder: DatasetFolder, rows: list[dict[str, Any]], options: dict[str, Any], seed: int,
                 maps: "set[str] | list[str] | tuple[str, ...]" = ()) -> None:
        self.folder, self.rows, self.seed = folder, rows, seed
        self.patch = options["patch_px"]
        self.flip, self.rotate = options["use_flip"], options["use_rot"]
        self.flags = _load_flags(maps, options)
        self.edges = EdgeCharts(folder, rows, options, maps) if options["edge_share"] > 0 else None

    def __len__(self) -> int:  # samples are addressed by number; any k is valid
        return 2**62

    def __getitem__(self, k: int) -> dict[str, Any]:
        rng = np.random.default_rng([self.seed, int(k)])
        # Without edge charts no draw is spent here, so such runs see the batches they always saw.
        if self.edges is not None and rng.random() < self.edges.share:
            return _tensors(augment(_sample(self.edges.sample(rng, self.patch), k), rng, self.flip, self.rotate))
        row = self.rows[_epoch_index(self.seed, int(k), len(self.rows))]
        _, _, width, height = (int(v) for v in row["crop"])
        p = self.patch
        if p > min(width, height):
            raise DatasetFolderError(f"datasets.train.patch_px: {p} px is larger than pair {row['pair_id']} ({width} x {height} px)")
        x, y = int(rng.integers(width - p + 1)), int(rng.integers(height - p + 1))
        pair = self.folder.load(row, window=(x, y, p, p), **self.flags)
        return _tensors(augment(_sample(pair, k), rng, self.flip, self.rotate))


class EdgeCharts:
    """Slanted-edge training samples: the bench's OIQE edge charts (an isolated grey edge, each colour
    channel through its own kernel, noise-free) imaged through a random stored field of a random
    training lens's PSF table (`unicac.table_edge_pairs`), with the bench's Wiener estimate. The bench
    scores edge sharpness on such charts of the test lenses; a model that saw only noisy photographs
    learns to smooth what Wiener sharpens there. They carry no FoV / PSF maps (the chart sits on the
    frame's +x axis, partly beyond the frame), so only models whose one map is `wiener` take them."""

    def __init__(self, folder: DatasetFolder, rows: list[dict[str, Any]], options: dict[str, Any],
                 maps: "set[str] | list[str] | tuple[str, ...]") -> None:
        others = sorted(set(maps) - {"wiener"})
        if others:
            raise DatasetFolderError(
                f"datasets.train.edge_share: edge charts carry no {', '.join(others)} map; use 0 for this model")
        self.folder, self.share, self.nsr = folder, float(options["edge_share"]), options["wiener_nsr"]
        self.tables = sorted({row["psf"] for row in rows if folder.has_psf(row)})
        if not self.tables:
            raise DatasetFolderError(
                f"datasets.train.edge_share: {folder.root}: no training lens has a PSF table to image edge charts with")
        self.fields = {table: len(folder._table_meta(table)["field_radius_norm"]) for table in self.tables}

    def sample(self, rng: np.random.Generator, patch: int) -> dict[str, Any]:
        """A `patch` px window of one chart, its centre within a quarter patch of the edge's centre
        (so the edge crosses the window), as `DatasetFolder.load` returns a pair window."""
        table = self.tables[int(rng.integers(len(self.tables)))]
        field = int(rng.integers(self.fields[table]))
        edge = ("vertical", "horizontal")[int(rng.integers(2))]
        (chart,) = _native.table_edge_pairs(str(self.folder.path(table)), field, min_edge_px=patch, nsr=self.nsr,
                                            edge=edge)
        side = chart["lq"].shape[0]
        reach = min((side - patch) // 2, patch // 4)
        x, y = ((side - patch) // 2 + int(rng.integers(-reach, reach + 1)) for _ in range(2))
        return {key: np.ascontiguousarray(chart[key][y : y + patch, x : x + patch]) for key in ("lq", "gt", "wiener")}


class FolderValidation(Dataset):  # type: ignore[type-arg]
    """`max_pairs` pairs of a split spread over its lenses (`spread_over_lenses`), centre-cropped to
    `crop_px` (no randomness)."""

    def __init__(self, folder: DatasetFolder, rows: list[dict[str, Any]], options: dict[str, Any],
                 maps: "set[str] | list[str] | tuple[str, ...]" = ()) -> None:
        self.folder, self.rows = folder, spread_over_lenses(rows, options["max_pairs"])
        self.crop, self.flags = options["crop_px"], _load_flags(maps, options)
        self.severe = severe_pairs(folder, self.rows)

    def __len__(self) -> int:
        return len(self.rows)

    def __getitem__(self, i: int) -> dict[str, Any]:
        row = self.rows[i]
        _, _, width, height = (int(v) for v in row["crop"])
        window = None
        if self.crop is not None and self.crop < min(width, height):
            window = ((width - self.crop) // 2, (height - self.crop) // 2, self.crop, self.crop)
        pair = self.folder.load(row, window=window, **self.flags)
        return _tensors(_sample(pair, i))


class OnTheFly(Dataset):  # type: ignore[type-arg]
    """Pairs simulated by `unicac.dataset.PairGenerator` (pair k is a pure function of (seed, k)); the FoV
    map of each patch from its position in the frame. With `augment_rng`, patches are flipped/rotated."""

    def __init__(self, generator: PairGenerator, fov: bool, flip: bool, rotate: bool, seed: Optional[int]) -> None:
        self.generator, self.fov = generator, fov
        self.flip, self.rotate, self.seed = flip, rotate, seed

    def __len__(self) -> int:
        return 2**62

    def __getitem__(self, k: int) -> dict[str, Any]:
        pair = self.generator.pair(int(k))
        sample = {"lq": to_chw(pair["degraded"]), "gt": to_chw(pair["sharp"]), "index": int(k)}
        if self.fov:
            x0, y0 = pair["origin_px"]
            w, h = self.generator.frame_px
            p = self.generator.patch_px
            sample["fov"] = _native.fov_map(w, h, x0, y0, p, p)
        if self.seed is not None:
            sample = augment(sample, np.random.default_rng([self.seed, 0xA06, int(k)]), self.flip, self.rotate)
        return _tensors(sample)


class Fixed(Dataset):  # type: ignore[type-arg]
    """A finite view 0..length-1 of a sample-numbered dataset (on-the-fly validation)."""

    def __init__(self, inner: Dataset, length: int) -> None:  # type: ignore[type-arg]
        self.inner, self.length = inner, length

    def __len__(self) -> int:
        return self.length

    def __getitem__(self, i: int) -> dict[str, Any]:
        if not 0 <= i < self.length:
            raise IndexError(i)
        return self.inner[i]


def _generator(options: dict[str, Any], split_key: str, seed: int, patch: int) -> PairGenerator:
    if not options["lenses"]:
        raise DatasetFolderError(f"datasets.{split_key}.lenses: type onthefly needs lens files or builtin:NAME")
    try:
        return PairGenerator(
            options["lenses"], options["images"], patch_px=patch, frame_px=tuple(options["frame_px"]), seed=seed,
            charts=options["charts"], isp=options["isp"], noise=options["noise"], task=options["task"],
        )
    except ValueError as error:  # names the generator's argument, which is the config key below datasets.SPLIT
        raise DatasetFolderError(f"datasets.{split_key}.{error}") from error


def _folder(options: dict[str, Any], split_key: str) -> DatasetFolder:
    if not options["dataroot"]:
        raise DatasetFolderError(f"datasets.{split_key}.dataroot: give a dataset folder (or --dataset DIR)")
    return DatasetFolder(options["dataroot"])


def _refuse_onthefly_psf(split_key: str, maps: "set[str] | list[str] | tuple[str, ...]") -> None:
    if any(m in TABLE_MAPS for m in maps):
        raise DatasetFolderError(
            f"datasets.{split_key}: this model needs PSF maps, which on-the-fly data does not provide; "
            "train it on a built dataset (unicac dataset build) that stores PSF tables"
        )


def _checked_folder(options: dict[str, Any], split_key: str, maps: "set[str] | list[str] | tuple[str, ...]"
                    ) -> tuple[DatasetFolder, list[dict[str, Any]]]:
    folder = _folder(options, split_key)
    rows = folder.check_split(options["split"], need_psf=any(m in TABLE_MAPS for m in maps))
    if "psf_code" in maps:
        folder.psf_basis()  # the code needs the dataset's basis: a clear error before training
    return folder, rows


def build_train_set(options: dict[str, Any], seed: int, maps: "set[str] | list[str] | tuple[str, ...]" = ()
                    ) -> Dataset:  # type: ignore[type-arg]
    """Training samples with the maps named in `maps` (any of fov, psf, psf_code, wiener)."""
    if options["type"] == "onthefly":
        _refuse_onthefly_psf("train", maps)
        if options["edge_share"] > 0:
            raise DatasetFolderError("datasets.train.edge_share: edge charts need a built dataset's PSF tables; use 0 for onthefly data")
        generator = _generator(options, "train", (seed ^ options["seed"]) % _SEED_BOUND, options["patch_px"])
        return OnTheFly(generator, "fov" in maps, options["use_flip"], options["use_rot"], seed)
    folder, rows = _checked_folder(options, "train", maps)
    return FolderPatches(folder, rows, options, seed, maps)


def build_val_set(options: dict[str, Any], maps: "set[str] | list[str] | tuple[str, ...]" = ()
                  ) -> Dataset:  # type: ignore[type-arg]
    if options["edge_share"] > 0:
        raise DatasetFolderError("datasets.val.edge_share: edge charts are for training only; validation scores the pairs")
    if options["type"] == "onthefly":
        _refuse_onthefly_psf("val", maps)
        # Its own seed, distinct from any training stream; crop_px sets the patch (None: 128).
        generator = _generator(options, "val", (options["seed"] + 0x7A1) % _SEED_BOUND, options["crop_px"] or 128)
        return Fixed(OnTheFly(generator, "fov" in maps, False, False, None), options["max_pairs"])
    folder, rows = _checked_folder(options, "val", maps)
    return FolderValidation(folder, rows, options, maps)
