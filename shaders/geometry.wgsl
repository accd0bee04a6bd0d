// The geometry of `unicac_sim::LensSimulator`'s image pass on the device, one channel at a time: the
// distortion warp (bilinear sample of the blurred region at each output pixel's ideal position, borders
// clamped) times the relative-illumination shading, both looked up in the simulator's radial tables
// (`unicac_sim::radial_table`) as the CPU path does, here in f32.

struct GeometryParams {
    // Output pixels (the window) and where they sit in the frame.
    width: u32,
    height: u32,
    window_x0: u32,
    window_y0: u32,
    // The blurred region and where it sits in the frame.
    source_width: u32,
    source_height: u32,
    source_x0: u32,
    source_y0: u32,
    centre_x: f32,
    centre_y: f32,
    // 1 when the warp / the shading is on (their tables are then bound).
    warp: u32,
    shade: u32,
    // Samples per table and samples per pixel of radius (`RADIAL_TABLE_STEP_PX`^-1).
    warp_samples: u32,
    shade_samples: u32,
    inverse_step: f32,
    _pad: u32,
}

@group(0) @binding(0) var<uniform> geometry_params: GeometryParams;
@group(0) @binding(1) var<storage, read> region: array<f32>;
@group(0) @binding(2) var<storage, read> warp_table: array<f32>;
@group(0) @binding(3) var<storage, read> shade_table: array<f32>;
@group(0) @binding(4) var<storage, read_write> warped: array<f32>;

// `RadialTable::at`: linear between samples, the last interval beyond them.
fn table_at(table: u32, samples: u32, radius: f32) -> f32 {
    let position = radius * geometry_params.inverse_step;
    let last = samples - 1u;
    let i = min(u32(max(position, 0.0)), last - 1u);
    let offset = position - f32(i);
    let t = select(0.0, min(offset, 1.0), offset > 0.0);
    if table == 0u {
        return warp_table[i] + t * (warp_table[i + 1u] - warp_table[i]);
    }
    return shade_table[i] + t * (shade_table[i + 1u] - shade_table[i]);
}

// The left (top) tap index and the weight of the next one for the position `whole + offset` on an
// axis of `length` samples, clamped to the axis like `BilinearTaps` (outside: the end sample, weight 0).
fn tap(whole: i32, offset: f32, length: u32) -> vec2<f32> {
    let step = floor(offset);
    let index = whole + i32(step);
    let fraction = offset - step;
    if index < 0 {
        return vec2<f32>(0.0, 0.0);
    }
    if index >= i32(length) - 1 {
        return vec2<f32>(f32(length - 1u), 0.0);
    }
    return vec2<f32>(f32(index), fraction);
}

@compute @workgroup_size(8, 8)
fn geometry(@builtin(global_invocation_id) id: vec3<u32>) {
    let p = geometry_params;
    if id.x >= p.width || id.y >= p.height {
        return;
    }
    let dx = f32(p.window_x0 + id.x) - p.centre_x;
    let dy = f32(p.window_y0 + id.y) - p.centre_y;
    let radius = sqrt(dx * dx + dy * dy);
    // The warp table holds scale - 1, so the output pixel's offset from its own frame position,
    // d (scale - 1), is small and exact to ~1e-6 px in f32: the source position is that pixel's
    // (integer) index in the region plus the offset, split into whole and fractional pixels without
    // ever holding the sum in f32 (whose spacing is 2.4e-4 px at 2000-4000 px).
    var stretch = 0.0;
    if p.warp == 1u {
        stretch = table_at(0u, p.warp_samples, radius);
    }
    var shade = 1.0;
    if p.shade == 1u {
        shade = table_at(1u, p.shade_samples, radius);
    }
    let w = p.source_width;
    let h = p.source_height;
    let x_tap = tap(i32(p.window_x0 + id.x) - i32(p.source_x0), dx * stretch, w);
    let y_tap = tap(i32(p.window_y0 + id.y) - i32(p.source_y0), dy * stretch, h);
    let x0 = u32(x_tap.x);
    let y0 = u32(y_tap.x);
    let tx = x_tap.y;
    let ty = y_tap.y;
    let top = y0 * w;
    let bottom = min(y0 + 1u, h - 1u) * w;
    let right = min(x0 + 1u, w - 1u);
    let upper = region[top + x0] * (1.0 - tx) + region[top + right] * tx;
    let lower = region[bottom + x0] * (1.0 - tx) + region[bottom + right] * tx;
    warped[id.y * p.width + id.x] = (upper * (1.0 - ty) + lower * ty) * shade;
}
