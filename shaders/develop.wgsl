// The development of a raw RGGB mosaic on the device, one output channel per dispatch (f32, as the CPU
// path's planes are): black level (`unicac_image::isp::subtract_black_level`), white balance on the
// mosaic (`apply_white_balance_mosaic`) and demosaicing (`demosaic`: bilinear or Malvar-He-Cutler, the
// taps of `demosaic_taps` in their order, mirrored borders). Every operation is a correctly rounded
// f32 subtraction, division, multiplication or addition in the CPU's order, so the CPU path is the twin.

struct DevelopParams {
    width: u32,
    height: u32,
    channel: u32,
    _pad0: u32,
    black_dn: f32,
    // White minus black level (DN), in f32 as the CPU forms it.
    range_dn: f32,
    gain_red: f32,
    gain_green: f32,
    gain_blue: f32,
    _pad1: u32,
    _pad2: u32,
    _pad3: u32,
}

@group(0) @binding(0) var<uniform> develop_params: DevelopParams;
@group(0) @binding(1) var<storage, read> dn: array<f32>;
// Words 0..24: (first tap, tap count) per (site, channel), site = 2 (y % 2) + x % 2; a count of 0 means
// the site's own sample. Then one word per tap: j * 5 + i (row y + j - 2, column x + i - 2).
@group(0) @binding(2) var<storage, read> tap_words: array<u32>;
// The weight of tap word t at t - 24.
@group(0) @binding(3) var<storage, read> tap_weights: array<f32>;
@group(0) @binding(4) var<storage, read_write> developed: array<f32>;

const TAP_TABLE_WORDS: u32 = 24u;

// Mirror index into 0..n without repeating the edge sample (unicac_image::isp::reflect).
fn reflect(index: i32, n: i32) -> i32 {
    if (n == 1) {
        return 0;
    }
    let period = 2 * (n - 1);
    var m = index % period;
    if (m < 0) {
        m = m + period;
    }
    return select(m, period - m, m >= n);
}

// The white-balanced exposure of photosite (x, y): ((DN - black) / range) * its colour's gain.
fn balanced(x: u32, y: u32) -> f32 {
    let p = develop_params;
    let v = (dn[y * p.width + x] - p.black_dn) / p.range_dn;
    let site = 2u * (y % 2u) + x % 2u;
    var gain = p.gain_green;
    if (site == 0u) {
        gain = p.gain_red;
    } else if (site == 3u) {
        gain = p.gain_blue;
    }
    return v * gain;
}

// The balanced samples a workgroup's 8 x 8 pixels read: its block and 2 more on every side, each
// computed once (the CPU, too, divides each sample once) and mirrored at the image's borders.
const TILE_SIDE: u32 = 12u;
var<workgroup> tile: array<f32, 144>;

@compute @workgroup_size(8, 8)
fn develop(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(local_invocation_id) local: vec3<u32>,
    @builtin(local_invocation_index) local_index: u32,
    @builtin(workgroup_id) group: vec3<u32>,
) {
    let p = develop_params;
    for (var k = local_index; k < TILE_SIDE * TILE_SIDE; k = k + 64u) {
        let column = reflect(i32(group.x * 8u + k % TILE_SIDE) - 2, i32(p.width));
        let row = reflect(i32(group.y * 8u + k / TILE_SIDE) - 2, i32(p.height));
        tile[k] = balanced(u32(column), u32(row));
    }
    workgroupBarrier();
    if (id.x >= p.width || id.y >= p.height) {
        return;
    }
    let slot = (2u * (id.y % 2u) + id.x % 2u) * 3u + p.channel;
    let first = tap_words[2u * slot];
    let count = tap_words[2u * slot + 1u];
    var value = 0.0;
    if (count == 0u) {
        value = tile[(local.y + 2u) * TILE_SIDE + local.x + 2u];
    } else {
        for (var t = first; t < first + count; t = t + 1u) {
            let tap = tap_words[t];
            value = value + tap_weights[t - TAP_TABLE_WORDS] * tile[(local.y + tap / 5u) * TILE_SIDE + local.x + tap % 5u];
        }
    }
    developed[id.y * p.width + id.x] = value;
}
