"""Flips and 90-degree rotations that move an image and its FoV / PSF-feature / PSF-code maps and its
Wiener estimate together.

A flipped or rotated crop is a crop seen through the mirrored or rotated lens: its pixels move, and
so do the field positions and PSF shapes they carry. So the maps are not only moved like the image;
their values change with the geometry (docs/models.md conventions, x right, y down):

* horizontal flip (x -> -x): fov x negated; PSF dx and sxy negated;
* vertical flip (y -> -y): fov y negated; PSF dy and sxy negated;
* transpose (x <-> y): fov channels swapped; PSF dx <-> dy and sxx <-> syy swapped;
* the PSF code's coefficients describe the kernel in its radial frame, the same for a kernel and its
  mirror image (crates/unicac-dataset/src/psf_basis.rs): they move with the pixels unchanged, and its
  last two channels (cos, sin of the azimuth) change as the FoV map's x and y;
* the Wiener estimate is an image: it moves like `lq`.

A rotation by 90 degrees is a transpose and a flip. Moving the image without its maps (or moving the
maps without changing their values) teaches the model a wrong prior; tests/test_train.py checks these
rules against maps computed directly at the mirrored and transposed positions.
"""

from __future__ import annotations

from typing import Optional

import numpy as np

PSF_FEATURES_PER_CHANNEL = 5  # dx, dy, sxx, sxy, syy
#: The PSF code's channels: coefficients, then cos and sin of the azimuth (docs/models.md).
CODE_COS, CODE_SIN = 48, 49


def _flip_image(chw: np.ndarray, axis: int) -> np.ndarray:
    return np.flip(chw, axis=axis)


def hflip_fov(fov: np.ndarray) -> np.ndarray:
    out = np.flip(fov, axis=2).copy()
    out[0] *= -1
    return out


def vflip_fov(fov: np.ndarray) -> np.ndarray:
    out = np.flip(fov, axis=1).copy()
    out[1] *= -1
    return out


def transpose_fov(fov: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(np.transpose(fov, (0, 2, 1))[[1, 0]])


def _psf_view(psf: np.ndarray) -> np.ndarray:
    return psf.reshape(3, PSF_FEATURES_PER_CHANNEL, *psf.shape[1:])


def hflip_psf(psf: np.ndarray) -> np.ndarray:
    out = np.flip(psf, axis=2).copy()
    v = _psf_view(out)
    v[:, 0] *= -1  # dx
    v[:, 3] *= -1  # sxy
    return out


def vflip_psf(psf: np.ndarray) -> np.ndarray:
    out = np.flip(psf, axis=1).copy()
    v = _psf_view(out)
    v[:, 1] *= -1  # dy
    v[:, 3] *= -1  # sxy
    return out


def transpose_psf(psf: np.ndarray) -> np.ndarray:
    out = np.ascontiguousarray(np.transpose(psf, (0, 2, 1)))
    v = _psf_view(out)
    v[:, [0, 1]] = v[:, [1, 0]]  # dx <-> dy
    v[:, [2, 4]] = v[:, [4, 2]]  # sxx <-> syy
    return out


def hflip_code(code: np.ndarray) -> np.ndarray:
    out = np.flip(code, axis=2).copy()
    out[CODE_COS] *= -1
    return out


def vflip_code(code: np.ndarray) -> np.ndarray:
    out = np.flip(code, axis=1).copy()
    out[CODE_SIN] *= -1
    return out


def transpose_code(code: np.ndarray) -> np.ndarray:
    out = np.ascontiguousarray(np.transpose(code, (0, 2, 1)))
    out[[CODE_COS, CODE_SIN]] = out[[CODE_SIN, CODE_COS]]
    return out


def augment(
    sample: dict[str, np.ndarray], rng: np.random.Generator, flip: bool, rotate: bool
) -> dict[str, np.ndarray]:
    """Draws one of the 8 flips/rotations (or the identity) from `rng` and applies it to `lq`, `gt`
    (C x H x W) and, when present, `wiener`, `fov`, `psf` and `psf_code`. The draws are made whatever
    the switches, so the random stream does not depend on them."""
    hflip, vflip, transpose = (bool(b) for b in rng.integers(0, 2, size=3))
    hflip, vflip = hflip and flip, vflip and flip
    transpose = transpose and rotate
    out = dict(sample)
    for key in ("lq", "gt", "wiener"):
        if key not in out:
            continue
        image = out[key]
        if hflip:
            image = _flip_image(image, 2)
        if vflip:
            image = _flip_image(image, 1)
        if transpose:
            image = np.transpose(image, (0, 2, 1))
        out[key] = np.ascontiguousarray(image)
    rules = {"fov": (hflip_fov, vflip_fov, transpose_fov), "psf": (hflip_psf, vflip_psf, transpose_psf),
             "psf_code": (hflip_code, vflip_code, transpose_code)}
    for key, (h_rule, v_rule, t_rule) in rules.items():
        value: Optional[np.ndarray] = out.get(key)
        if value is None:
            continue
        if hflip:
            value = h_rule(value)
        if vflip:
            value = v_rule(value)
        if transpose:
            value = t_rule(value)
        out[key] = np.ascontiguousarray(value, dtype=np.float32)
    return out
