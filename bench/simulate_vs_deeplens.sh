#!/usr/bin/env bash
# DeepLens side by side (issue 34): one unicac lens in both tools (bench/peers/deeplens_lens.py converts
# it; DeepLens is deeplens-core 2.5.6 from PyPI, Python 3.12, in its own venv), then
#   1. refractive indices, RMS spot radius (the same 256 x 256 pupil grid, paraxial aiming, primary
#      wavelength) per field and the geometric PSF at one field (same pixel pitch), side by side;
#   2. image simulation wall time, whole processes, cold (unicac --no-cache), interleaved ROUNDS times
#      (default 2) and the best of each kept, for
#        unicac simulate --no-isp --no-noise (its defaults: 31 wavelengths x 17 radial PSFs of 2048 rays,
#                                             blended between kernel nodes)
#        DeepLens render(method="psf_map") at its defaults (3 wavelengths x 10 x 10 PSFs of 8192 rays,
#                                             64 px kernels, tiles without blending, inverse-distortion warp)
#        DeepLens "equal work": 3 x 13 x 13 = 507 PSFs (unicac: 527) of 2048 rays, unicac's kernel size
#      on the same image (a dead-leaves chart WxH, default 1024x768) at the same pixel pitch.
# Prints JSON lines; the machine and its load first. Usage:
#   bash bench/simulate_vs_deeplens.sh [LENS] [WxH] [ROUNDS]   (needs target/release/unicac)
# UNICAC_BIN runs another build of the binary (the test profile is optimised alike: opt-level 3).
# DEEPLENS_VENV points at an existing venv with deeplens-core==2.5.6 (default bench/.venv-deeplens,
# created with python3.12 when missing: about 3 GB of wheels, mostly CUDA libraries torch pulls in).
set -euo pipefail
cd "$(dirname "$0")/.."
lens=${1:-cooke_triplet}
size=${2:-1024x768}
rounds=${3:-2}
venv=${DEEPLENS_VENV:-bench/.venv-deeplens}
unicac=${UNICAC_BIN:-$PWD/target/release/unicac}
[[ $rounds =~ ^[1-9][0-9]*$ ]] || { echo "ROUNDS must be a positive integer, not '$rounds'" >&2; exit 1; }
[[ $size =~ ^[1-9][0-9]*x[1-9][0-9]*$ ]] || { echo "WxH must look like 1024x768, not '$size'" >&2; exit 1; }
[ -f "lenses/$lens.json" ] || { echo "no lens lenses/$lens.json" >&2; exit 1; }
[ -x "$unicac" ] || { echo "build it first: cargo build --release -p unicac-cli" >&2; exit 1; }
if [ ! -x "$venv/bin/python" ]; then
  command -v python3.12 >/dev/null || { echo "DeepLens needs Python 3.12 (python3.12 not on PATH)" >&2; exit 1; }
  python3.12 -m venv "$venv"
  "$venv/bin/pip" install -q deeplens-core==2.5.6
fi
py=$venv/bin/python
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# Wall time of one run; a failing run stops the script with its error output.
wall() {
  local t0 t1
  t0=$(date +%s.%N)
  "$@" >"$work/last.out" 2>"$work/last.err" || { echo "failed: $*" >&2; tail -5 "$work/last.err" >&2; return 1; }
  t1=$(date +%s.%N)
  echo "$t1 - $t0" | bc
}
echo "# machine: $(nproc) cores, $(lscpu | sed -n 's/^Model name: *//p'), $(date -u +%Y-%m-%dT%H:%MZ), load $(cut -d' ' -f1-3 /proc/loadavg)"

# --- 1. agreement --------------------------------------------------------------------------------
read -r field primary pixel < <("$unicac" lens info "builtin:$lens" --json | "$py" -c "
import json, math, sys
info = json.load(sys.stdin); spec = json.load(open('lenses/$lens.json'))
fields = spec['fields']['angles_deg']; mid = fields[len(fields) // 2]
w = spec['wavelengths'][spec.get('primary_wavelength_index', 0)]['wavelength_um']
print(mid, w, 4.0)")
kernel=31
"$unicac" spot "builtin:$lens" --pupil-sampling grid:256 --aim paraxial --wavelength-um "$primary" --json > "$work/spot.json"
"$unicac" psf "builtin:$lens" --field-deg "$field" --wavelength-um "$primary" --pixel-um "$pixel" \
  --max-kernel-px "$kernel" --no-cache --out "$work/psf.exr" --json > "$work/psf.json"
"$py" bench/peers/deeplens_agreement.py "$lens" "$field" "$pixel" "$kernel" 256 2>/dev/null | tail -1 > "$work/deeplens.json"
"$py" - "$work" <<'PY'
import json, struct, sys, zlib
import numpy as np
work = sys.argv[1]
spot = json.load(open(f"{work}/spot.json"))["spots"]
peer = json.load(open(f"{work}/deeplens.json"))
meta = json.load(open(f"{work}/psf.json"))

def read_exr(path):
    """First channel of a single-part scanline EXR of f32 samples, raw or ZIP (unicac's PSF files)."""
    b = open(path, "rb").read()
    pos, attrs = 8, {}
    while b[pos] != 0:
        name_end = b.index(0, pos); name = b[pos:name_end].decode()
        type_end = b.index(0, name_end + 1)
        size = struct.unpack_from("<i", b, type_end + 1)[0]
        attrs[name] = b[type_end + 5:type_end + 5 + size]
        pos = type_end + 5 + size
    pos += 1
    x0, y0, x1, y1 = struct.unpack("<4i", attrs["dataWindow"])
    width, height = x1 - x0 + 1, y1 - y0 + 1
    names = [n for n in attrs["channels"].split(b"\0") if n and len(n) < 32 and n.isalnum()]
    count = len(names)
    per_chunk = {0: 1, 2: 1, 3: 16}[attrs["compression"][0]]
    chunks = -(-height // per_chunk)
    offsets = struct.unpack_from(f"<{chunks}Q", b, pos)
    rows = []
    for offset in offsets:
        y, size = struct.unpack_from("<ii", b, offset)
        data = b[offset + 8:offset + 8 + size]
        lines = min(per_chunk, y1 - y + 1)
        expected = lines * count * width * 4
        if size < expected:
            t = bytearray(zlib.decompress(data))
            for i in range(1, len(t)):
                t[i] = (t[i - 1] + t[i] - 128) & 0xFF
            half = (len(t) + 1) // 2
            out = bytearray(len(t)); out[0::2] = t[:half]; out[1::2] = t[half:]
            data = bytes(out)
        block = np.frombuffer(data, dtype="<f4").reshape(lines, count, width)
        rows.extend(block[:, 0, :])
    return np.array(rows, dtype=np.float64)

ours = read_exr(f"{work}/psf.exr")
theirs = np.array(peer["psf"]["kernel"])
size = max(len(ours), len(theirs))
def pad(k):
    m = (size - len(k)) // 2
    return np.pad(k / k.sum(), m)
a, b = pad(ours), pad(theirs)
c = (np.arange(size) - (size - 1) / 2) * meta["pixel_um"]
def radius(k):
    cy, cx = (k.sum(1) * c).sum(), (k.sum(0) * c).sum()
    return float(np.sqrt((k * ((c[None] - cx) ** 2 + (c[:, None] - cy) ** 2)).sum()))
for s, d in zip(spot, peer["spots"]):
    print(json.dumps({"field_deg": s["field_deg"], "wavelength_um": s["wavelength_um"],
                      "unicac_rms_um": s["rms_radius_um"], "deeplens_rms_um": d["rms_radius_um"],
                      "relative_difference": (d["rms_radius_um"] - s["rms_radius_um"]) / s["rms_radius_um"],
                      "unicac_rays_ok": s["rays_ok"], "deeplens_rays_ok": d["rays_ok"]}))
print(json.dumps({"psf_field_deg": peer["psf"]["field_deg"], "pixel_um": meta["pixel_um"],
                  "unicac_kernel_px": len(ours), "deeplens_kernel_px": len(theirs),
                  "unicac_second_moment_um": radius(a), "deeplens_second_moment_um": radius(b),
                  "half_l1_distance": float(0.5 * np.abs(a - b).sum()),
                  "deeplens_indices": peer["indices"]}))
PY

# --- 2. image simulation timing ------------------------------------------------------------------
read -r width height <<<"${size/x/ }"
image=$work/dead-leaves-$size.png
"$unicac" chart dead-leaves --size "$size" --seed 7 --out "$image" >/dev/null
read -r sim_pixel sim_kernel < <("$unicac" lens info "builtin:$lens" --json | "$py" -c "
import json, math, subprocess, sys
info = json.load(sys.stdin); spec = json.load(open('lenses/$lens.json'))
fields = spec['fields']['angles_deg']
pixel = info['efl_mm'] * math.tan(math.radians(max(fields))) / (math.hypot($width, $height) / 2) * 1e3
sizes = [json.loads(subprocess.run(['$unicac', 'psf', 'builtin:$lens', '--field-deg', str(f), '--pixel-um', str(pixel),
         '--no-cache', '--out', '$work/k.exr', '--json'], capture_output=True, text=True, check=True).stdout)['kernel_px']
         for f in fields]
print(pixel, max(sizes))")
declare -A best
keep() { local key=$1 value=$2; if [ -z "${best[$key]:-}" ] || (( $(echo "$value < ${best[$key]}" | bc) )); then best[$key]=$value; fi; }
for round in $(seq "$rounds"); do
  t=$(wall "$unicac" simulate "builtin:$lens" "$image" --out "$work/out-$round" --no-cache --no-isp --no-noise --device cpu)
  rm -rf "$work/out-$round"; keep unicac "$t"
  t=$(wall "$py" bench/peers/deeplens_image_simulation.py "$lens" "$image"); keep deeplens "$t"
  keep deeplens_render "$(tail -1 "$work/last.out" | "$py" -c 'import json,sys; print(json.load(sys.stdin)["seconds"])')"
  t=$(wall "$py" bench/peers/deeplens_image_simulation.py "$lens" "$image" --grid 13 --kernel-px "$sim_kernel" --spp 2048)
  keep equal "$t"
  keep equal_render "$(tail -1 "$work/last.out" | "$py" -c 'import json,sys; print(json.load(sys.stdin)["seconds"])')"
  echo "# round $round done, load $(cut -d' ' -f1-3 /proc/loadavg)"
done
"$py" - "$lens" "$size" "$rounds" "$sim_pixel" "$sim_kernel" "${best[unicac]}" "${best[deeplens]}" "${best[deeplens_render]}" \
  "${best[equal]}" "${best[equal_render]}" <<'PY'
import json, sys
lens, size, rounds, pixel, kernel, u, d, dr, e, er = sys.argv[1:]
u, d, dr, e, er = map(float, (u, d, dr, e, er))
print(json.dumps({"lens": lens, "size": size, "rounds": int(rounds), "pixel_um": round(float(pixel), 4),
                  "unicac_kernel_px": int(kernel), "unicac_process_s": round(u, 2),
                  "deeplens_defaults_process_s": round(d, 2), "deeplens_defaults_render_s": dr,
                  "deeplens_equal_work_process_s": round(e, 2), "deeplens_equal_work_render_s": er,
                  "ratio_defaults_process": round(d / u, 2), "ratio_equal_work_process": round(e / u, 2),
                  "ratio_equal_work_render_only": round(er / u, 2)}))
PY
