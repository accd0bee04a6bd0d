// The project's counter-based random source on the device (unicac_io::counter_random): SplitMix64 on
// 64-bit integers held as (low, high) u32 pairs, since WGSL has no portable u64. Joined before
// common.wgsl (the ray kernels) and before sensor.wgsl (the read-out); no bindings, no `Real`.

fn mul_wide(a: u32, b: u32) -> vec2<u32> {
    let a0 = a & 0xffffu;
    let a1 = a >> 16u;
    let b0 = b & 0xffffu;
    let b1 = b >> 16u;
    let p00 = a0 * b0;
    let p01 = a0 * b1;
    let p10 = a1 * b0;
    let p11 = a1 * b1;
    let mid = (p00 >> 16u) + (p01 & 0xffffu) + (p10 & 0xffffu);
    return vec2<u32>((p00 & 0xffffu) | (mid << 16u), p11 + (p01 >> 16u) + (p10 >> 16u) + (mid >> 16u));
}

fn mul64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let w = mul_wide(a.x, b.x);
    return vec2<u32>(w.x, w.y + a.y * b.x + a.x * b.y);
}

fn add64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let lo = a.x + b.x;
    return vec2<u32>(lo, a.y + b.y + select(0u, 1u, lo < a.x));
}

// Right shift by 0 < s < 32.
fn shr64(a: vec2<u32>, s: u32) -> vec2<u32> {
    return vec2<u32>((a.x >> s) | (a.y << (32u - s)), a.y >> s);
}

fn xor_shr64(a: vec2<u32>, s: u32) -> vec2<u32> {
    return a ^ shr64(a, s);
}

const GOLDEN_GAMMA: vec2<u32> = vec2<u32>(0x7f4a7c15u, 0x9e3779b9u);

// SplitMix64's output function (unicac_io::counter_random::finalise).
fn finalise(state: vec2<u32>) -> vec2<u32> {
    var z = mul64(xor_shr64(state, 30u), vec2<u32>(0x1ce4e5b9u, 0xbf58476du));
    z = mul64(xor_shr64(z, 27u), vec2<u32>(0x133111ebu, 0x94d049bbu));
    return xor_shr64(z, 31u);
}

// The counter-th number of stream `seed`, bit for bit unicac_io::counter_random::counter_hash.
fn counter_hash(seed: vec2<u32>, counter: vec2<u32>) -> vec2<u32> {
    return finalise(add64(seed ^ mul64(counter, GOLDEN_GAMMA), GOLDEN_GAMMA));
}

// Sub-stream `stream` of `seed`, bit for bit unicac_io::counter_random::derive_seed.
fn derive_seed(seed: vec2<u32>, stream: vec2<u32>) -> vec2<u32> {
    return finalise(add64(seed, mul64(stream, GOLDEN_GAMMA)));
}
