// trace.wgsl: batched sequential ray tracing. Appended to common.wgsl (see its header). One invocation
// per ray, workgroups of 64 (WORKGROUP); twin: crates/unicac-gpu/src/twin.rs `trace_kernel`.
//
// Input: host rays in `rays` (pattern 0, position local to surface 1's vertex) or pattern slots
// first_index .. first_index + ray_count sampled and aimed on the device. Output, per ray: `rays[i]`
// (local to the vertex of the last surface reached) and `statuses[i]` (kind | UNDECIDED? | surface << 8);
// the status histogram is added to `counters`.
@compute @workgroup_size(64)
fn trace_rays(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) local: u32) {
    let i = gid.x;
    var kind = 8u;  // out of range: counted nowhere
    if (i < params.ray_count) {
        kind = OK;
        var ray = source_ray(i, &kind);
        var status = status_word(NOT_SAMPLED, 0u);
        if (kind != NOT_SAMPLED) {
            status = trace_ray(&ray);
            kind = status & 0x7fu;
        }
        rays[i] = ray;
        statuses[i] = status;
    }
    count_status(local, kind);
}
