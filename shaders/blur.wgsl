// The blur of `unicac_sim::LensSimulator`'s image pass on the device, one channel at a time (f32, as the
// CPU path's planes are): the spatially varying convolution of `unicac_sim::convolve` (the gather blend
// of the four corner kernels of each pixel's tile, each cropped to the tile's half-width, replicated
// borders). The tile of every pixel, its blend position and each tile's crop come from the host
// (`unicac_sim::convolve::TileLayout`), so both paths blend by the same weights. geometry.wgsl follows.

struct BlurParams {
    width: u32,
    height: u32,
    // First row of this dispatch's band (bands keep each dispatch short).
    row_start: u32,
    rows: u32,
    tiles_x: u32,
    // Side of the node kernels as stored (odd).
    kernel_size: u32,
    nodes_x: u32,
    // 1: the nearest corner only (`Blend::Nearest`); 0: bilinear weights.
    nearest: u32,
    // Offsets into `layout_u32`: row tiles (height), tile half-widths; column tiles start at 0.
    row_tile_at: u32,
    tile_half_at: u32,
    // Offset into `layout_f32` of the row positions; column positions start at 0.
    row_t_at: u32,
    // Offsets of the flat tiles: a flag per tile in `layout_u32`, four corner values per tile in
    // `layout_f32` (`TileLayout::flat_tiles`: the CPU path's shortcut for tiles over flat input).
    flat_at: u32,
    flat_values_at: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> blur_params: BlurParams;
@group(0) @binding(1) var<storage, read> plane: array<f32>;
@group(0) @binding(2) var<storage, read> kernels: array<f32>;
@group(0) @binding(3) var<storage, read> layout_u32: array<u32>;
@group(0) @binding(4) var<storage, read> layout_f32: array<f32>;
@group(0) @binding(5) var<storage, read_write> blurred: array<f32>;

// (I * K)(column, row) for node kernel `node` cropped to half-width `half`: sum over kernel samples
// K(u, v) I(p - (u, v)), the border replicated; the summation order of `convolve::direct` (interior
// rows summed on their own first).
fn convolve_at(node: u32, half: u32, column: u32, row: u32) -> f32 {
    let p = blur_params;
    let size = 2u * half + 1u;
    let offset = (p.kernel_size - size) / 2u;
    let base = node * p.kernel_size * p.kernel_size;
    let first = i32(column) + i32(half);
    let interior = first - i32(size) + 1 >= 0 && first < i32(p.width);
    var sum = 0.0;
    for (var kr = 0u; kr < size; kr++) {
        let source_row = u32(clamp(i32(row) - (i32(kr) - i32(half)), 0, i32(p.height) - 1));
        let source = source_row * p.width;
        let kernel_row = base + (kr + offset) * p.kernel_size + offset;
        if interior {
            var row_sum = 0.0;
            for (var kc = 0u; kc < size; kc++) {
                row_sum += kernels[kernel_row + kc] * plane[source + u32(first - i32(kc))];
            }
            sum += row_sum;
        } else {
            for (var kc = 0u; kc < size; kc++) {
                let source_column = u32(clamp(first - i32(kc), 0, i32(p.width) - 1));
                sum += kernels[kernel_row + kc] * plane[source + source_column];
            }
        }
    }
    return sum;
}

@compute @workgroup_size(8, 8)
fn blur(@builtin(global_invocation_id) id: vec3<u32>) {
    let p = blur_params;
    let column = id.x;
    let row = p.row_start + id.y;
    if column >= p.width || id.y >= p.rows || row >= p.height {
        return;
    }
    let i = layout_u32[column];
    let j = layout_u32[p.row_tile_at + row];
    let tx = layout_f32[column];
    let ty = layout_f32[p.row_t_at + row];
    let half = layout_u32[p.tile_half_at + j * p.tiles_x + i];
    var weights: array<f32, 4>;
    if p.nearest == 1u {
        let corner = select(0u, 1u, tx >= 0.5) + select(0u, 2u, ty >= 0.5);
        weights[corner] = 1.0;
    } else {
        weights = array<f32, 4>((1.0 - tx) * (1.0 - ty), tx * (1.0 - ty), (1.0 - tx) * ty, tx * ty);
    }
    let nodes = array<u32, 4>(
        j * p.nodes_x + i,
        j * p.nodes_x + i + 1u,
        (j + 1u) * p.nodes_x + i,
        (j + 1u) * p.nodes_x + i + 1u,
    );
    let tile = j * p.tiles_x + i;
    let flat = layout_u32[p.flat_at + tile] == 1u;
    var value = 0.0;
    for (var n = 0u; n < 4u; n++) {
        // A corner whose weight is zero here costs nothing; over flat input it costs no convolution.
        var corner = 0.0;
        if flat {
            corner = layout_f32[p.flat_values_at + 4u * tile + n];
        } else if weights[n] != 0.0 {
            corner = convolve_at(nodes[n], half, column, row);
        }
        value += corner * weights[n];
    }
    blurred[row * p.width + column] = value;
}

