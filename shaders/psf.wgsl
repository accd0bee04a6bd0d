// psf.wgsl: PSF accumulation. Appended to common.wgsl (see its header). One invocation per ray; twin:
// crates/unicac-gpu/src/twin.rs `accumulate_kernel`.
//
// Each ray that arrives is splatted bilinearly onto the supersampled grid (fine_size^2 cells per
// channel, the layout of unicac_psf::kernel::rasterise), in micrometres relative to the chief ray
// (x right, y down the rows), with its R, G, B spectral weights. Sums are 64-bit fixed point
// (FIXED_SCALE units per unit weight) added with u32 atomics and an explicit carry: integer addition
// is associative, so the grid is the same bit for bit whatever the order invocations run in.

const FIXED_SCALE: Real = Real(17592186044416.0);      // 2^44: headroom 2^20 over unit total weight
const INV_2_32: Real = Real(2.3283064365386963e-10);    // 2^-32
const TWO_32: Real = Real(4294967296.0);

// Non-negative weight as 64-bit fixed point (low, high), rounded to nearest.
fn to_fixed(weight: Real) -> vec2<u32> {
    let scaled = floor(weight * FIXED_SCALE + Real(0.5));
    let high = floor(scaled * INV_2_32);
    return vec2<u32>(u32(scaled - high * TWO_32), u32(high));
}

fn add_fixed(word: u32, value: vec2<u32>) {
    if (value.x == 0u && value.y == 0u) {
        return;
    }
    let old = atomicAdd(&grid[word], value.x);
    // The low word wrapped exactly when old + low overflows; the carry goes into the high word.
    let carry = select(0u, 1u, old + value.x < old);
    if (value.y + carry != 0u) {
        atomicAdd(&grid[word + 1u], value.y + carry);
    }
}

fn splat(x_mm: Real, y_mm: Real) {
    let fine = params.fine_size;
    let centre = Real(fine) * Real(0.5);
    // Offsets from the chief ray first: the difference of two nearby coordinates is exact.
    let ox_um = (x_mm - params.chief_x_mm) * Real(1000.0);
    let oy_um = -(y_mm - params.chief_y_mm) * Real(1000.0);
    let fx = ox_um / params.sub_pitch_um + centre - Real(0.5);
    let fy = oy_um / params.sub_pitch_um + centre - Real(0.5);
    // Far outside the grid (or not finite): nothing to add, and no overflow in the integer cast.
    if (!(abs(fx - centre) < centre + Real(2.0) && abs(fy - centre) < centre + Real(2.0))) {
        return;
    }
    let x0 = floor(fx);
    let y0 = floor(fy);
    let tx = fx - x0;
    let ty = fy - y0;
    let weights = array<Real, 3>(params.weight_r, params.weight_g, params.weight_b);
    for (var dy = 0; dy < 2; dy += 1) {
        let y = i32(y0) + dy;
        let wy = select(Real(1.0) - ty, ty, dy == 1);
        for (var dx = 0; dx < 2; dx += 1) {
            let x = i32(x0) + dx;
            let wx = select(Real(1.0) - tx, tx, dx == 1);
            if (x >= 0 && y >= 0 && u32(x) < fine && u32(y) < fine) {
                let cell = u32(y) * fine + u32(x);
                for (var c = 0u; c < 3u; c += 1u) {
                    add_fixed(2u * (c * fine * fine + cell), to_fixed(weights[c] * wx * wy));
                }
            }
        }
    }
}

@compute @workgroup_size(64)
fn accumulate_psf(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) local: u32) {
    let i = gid.x;
    var kind = 8u;
    if (i < params.ray_count) {
        kind = OK;
        var ray = source_ray(i, &kind);
        if (kind != NOT_SAMPLED) {
            // The PSF takes the working precision's verdict on undecided rays (a sub-ppm effect on
            // the kernel), so nothing comes back but the grid.
            kind = trace_ray(&ray) & 0x7fu;
            if (kind == OK) {
                splat(ray.x, ray.y);
            }
        }
    }
    count_status(local, kind);
}
