// Lambert-shaded triangles. Positions arrive in clip space (the host transforms the few
// thousand vertices of a frame itself), so the pipeline needs no uniforms or descriptors.

struct Vertex {
    @location(0) clip: vec4<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) colour: vec4<f32>,
};

struct Varying {
    @builtin(position) clip: vec4<f32>,
    @location(0) normal: vec3<f32>,
    @location(1) colour: vec4<f32>,
};

@vertex
fn vertex_main(v: Vertex) -> Varying {
    var out: Varying;
    out.clip = v.clip;
    out.normal = v.normal;
    out.colour = v.colour;
    return out;
}

// Light from above, in front and to the left; a quarter of ambient so faces turned away
// still show their colour. A zero normal marks lines and overlays: drawn unshaded.
@fragment
fn fragment_main(f: Varying) -> @location(0) vec4<f32> {
    let n = length(f.normal);
    if (n < 1e-6) {
        return f.colour;
    }
    let light = normalize(vec3<f32>(-0.4, 1.0, 0.6));
    let lambert = max(dot(f.normal / n, light), 0.0);
    return vec4<f32>(f.colour.rgb * (0.25 + 0.75 * lambert), f.colour.a);
}
