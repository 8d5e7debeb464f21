// Lambert-shaded triangles with shadows. Positions arrive in clip space, both the camera's
// and the light's (the host transforms the few thousand vertices of a frame itself), so the
// only resource is the shadow map.

struct Vertex {
    @location(0) clip: vec4<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) colour: vec4<f32>,
    @location(3) light: vec4<f32>,
};

struct Varying {
    @builtin(position) clip: vec4<f32>,
    @location(0) normal: vec3<f32>,
    @location(1) colour: vec4<f32>,
    @location(2) light: vec4<f32>,
};

// The depth of what the light sees first, drawn by `shadow_main` before each frame.
@group(0) @binding(0) var shadow_map: texture_depth_2d;
@group(0) @binding(1) var shadow_sampler: sampler_comparison;

@vertex
fn vertex_main(v: Vertex) -> Varying {
    var out: Varying;
    out.clip = v.clip;
    out.normal = v.normal;
    out.colour = v.colour;
    out.light = v.light;
    return out;
}

// The light's view of the scene, depth only. Vertices that cast no shadow arrive beyond
// its far plane and are clipped.
@vertex
fn shadow_main(v: Vertex) -> @builtin(position) vec4<f32> {
    return v.light;
}

// How much of the light reaches a point seen at `light` (its light-space clip position):
// one comparison, filtered over the four nearest texels for a soft edge.
fn lit(light: vec4<f32>) -> f32 {
    let p = light.xyz / light.w;
    // Vertex positions are turned y down for Vulkan, the light's view too.
    let uv = vec2<f32>(p.x * 0.5 + 0.5, 0.5 - p.y * 0.5);
    if (any(uv < vec2<f32>(0.0)) || any(uv > vec2<f32>(1.0)) || p.z > 1.0) {
        return 1.0;
    }
    return textureSampleCompareLevel(shadow_map, shadow_sampler, uv, p.z - 0.0015);
}

// Light from above, in front and to the left (the host's `light::direction`); a quarter of ambient so
// faces turned away still show their colour, and shadows keep a third of the direct light
// so what lies in them stays readable. A zero normal marks lines and overlays: unshaded.
@fragment
fn fragment_main(f: Varying) -> @location(0) vec4<f32> {
    let n = length(f.normal);
    if (n < 1e-6) {
        return f.colour;
    }
    let light = normalize(vec3<f32>(-0.4, 1.0, 0.6));
    let lambert = max(dot(f.normal / n, light), 0.0);
    let direct = 0.75 * lambert * (0.35 + 0.65 * lit(f.light));
    return vec4<f32>(f.colour.rgb * (0.25 + direct), f.colour.a);
}
