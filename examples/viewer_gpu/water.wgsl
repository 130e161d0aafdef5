// Screen-space water on the GPU: the passes of `water.rs` (one module, one entry point pair
// per pass). View space: camera at the origin looking down -z; "depth" is the distance along
// -z (m). The fluid depth texture holds FAR where there is no fluid.

struct Frame {
    view: mat4x4<f32>,      // world -> view
    proj: mat4x4<f32>,      // view -> clip (wgpu depth range 0..1)
    screen: vec4<f32>,      // width, height, focal length (px), unused
    blur: vec4<f32>,        // footprint half-width (m), range mu (m), max footprint (px), unused
    light: vec4<f32>,       // direction to the sun, view space
    up: vec4<f32>,          // world up, view space
    absorption: vec4<f32>,  // Beer-Lambert per channel (per spacing), refraction strength
    deep: vec4<f32>,        // deep-water colour, particle spacing (m)
};

@group(0) @binding(0) var<uniform> F: Frame;

const FAR: f32 = 1.0e30;

// ---- colliders' depth (occludes the fluid) ----

@vertex
fn vs_collider(@location(0) p: vec3<f32>) -> @builtin(position) vec4<f32> {
    return F.proj * (F.view * vec4<f32>(p, 1.0));
}

// ---- ellipsoid splats (depth, thickness, foam) ----

struct Splat {
    @builtin(position) clip: vec4<f32>,
    @location(0) ray: vec3<f32>,                    // view-space point on the quad
    @location(1) @interpolate(flat) c: vec3<f32>,   // center, view space
    @location(2) @interpolate(flat) m0: vec3<f32>,  // rows of the inverse map, view space
    @location(3) @interpolate(flat) m1: vec3<f32>,
    @location(4) @interpolate(flat) m2: vec3<f32>,
    @location(5) @interpolate(flat) weight: f32,
};

// A camera-facing quad in front of the ellipsoid's bounding sphere, covering its silhouette.
@vertex
fn vs_splat(
    @builtin(vertex_index) vi: u32,
    @location(0) center: vec4<f32>,   // xyz, bounding radius
    @location(1) r0: vec4<f32>,       // rows axes[k] / radii[k] (world), w: weight (foam)
    @location(2) r1: vec4<f32>,
    @location(3) r2: vec4<f32>,
) -> Splat {
    var corners = array<vec2<f32>, 6>(
        vec2<f32>(-1.0, -1.0), vec2<f32>(1.0, -1.0), vec2<f32>(1.0, 1.0),
        vec2<f32>(-1.0, -1.0), vec2<f32>(1.0, 1.0), vec2<f32>(-1.0, 1.0),
    );
    var out: Splat;
    let c = (F.view * vec4<f32>(center.xyz, 1.0)).xyz;
    let r = center.w;
    let d = -c.z;
    out.c = c;
    out.m0 = (F.view * vec4<f32>(r0.xyz, 0.0)).xyz;
    out.m1 = (F.view * vec4<f32>(r1.xyz, 0.0)).xyz;
    out.m2 = (F.view * vec4<f32>(r2.xyz, 0.0)).xyz;
    out.weight = r0.w;
    if (d - r < 0.02) {
        out.clip = vec4<f32>(2.0, 2.0, 2.0, 1.0); // behind or at the near plane: culled
        out.ray = vec3<f32>(0.0, 0.0, -1.0);
        return out;
    }
    // The silhouette cone's radius at the quad's distance d - r, widened by the quad's
    // offset from the axis (the quad is a plane, the cone is not).
    let dq = d - r;
    let s = dq * r / sqrt(max(d * d - r * r, 1e-12));
    let k = 1.0 + length(c.xy) / d;
    let corner = corners[vi];
    let q = vec3<f32>(c.xy * (dq / d) + corner * s * k * 1.05, -dq);
    out.ray = q;
    out.clip = F.proj * vec4<f32>(q, 1.0);
    return out;
}

struct Hit {
    near: f32,
    far: f32,
};

// Ray (through `ray`, from the eye) against the ellipsoid: depths along -z of both crossings,
// or near < 0 for a miss.
fn hit(in: Splat) -> Hit {
    let dir = in.ray / -in.ray.z;
    let u = vec3<f32>(dot(in.m0, dir), dot(in.m1, dir), dot(in.m2, dir));
    let w = vec3<f32>(dot(in.m0, in.c), dot(in.m1, in.c), dot(in.m2, in.c));
    let a = dot(u, u);
    let b = dot(u, w);
    let disc = b * b - a * (dot(w, w) - 1.0);
    if (disc <= 0.0) {
        return Hit(-1.0, -1.0);
    }
    let root = sqrt(disc);
    return Hit((b - root) / a, (b + root) / a);
}

fn clip_depth(in: Splat, t: f32) -> f32 {
    let p = in.ray / -in.ray.z * t;
    let clip = F.proj * vec4<f32>(p, 1.0);
    return clip.z / clip.w;
}

struct DepthOut {
    @location(0) depth: f32,
    @builtin(frag_depth) z: f32,
};

@fragment
fn fs_depth(in: Splat) -> DepthOut {
    let h = hit(in);
    if (h.near < 0.02) {
        discard;
    }
    return DepthOut(h.near, clip_depth(in, h.near));
}

struct ThickOut {
    @location(0) thickness: f32,
    @builtin(frag_depth) z: f32,
};

@fragment
fn fs_thickness(in: Splat) -> ThickOut {
    let h = hit(in);
    if (h.near < 0.02) {
        discard;
    }
    return ThickOut(h.far - h.near, clip_depth(in, h.near));
}

// Foam, spray and bubbles: soft round dots of coverage (weight per kind in `weight`).
@fragment
fn fs_foam(in: Splat) -> ThickOut {
    let h = hit(in);
    if (h.near < 0.02) {
        discard;
    }
    // (1 - rho^2)^2 of the CPU path's dot, rho the distance from the dot's center over its
    // radius: the chord over the diameter is sqrt(1 - rho^2).
    let c = (h.far - h.near) * length(in.m0) * 0.5;
    return ThickOut(in.weight * c * c * c * c, clip_depth(in, h.near));
}

// ---- full-screen passes ----

@vertex
fn vs_full(@builtin(vertex_index) vi: u32) -> @builtin(position) vec4<f32> {
    let x = f32((vi << 1u) & 2u) * 2.0 - 1.0;
    let y = f32(vi & 2u) * 2.0 - 1.0;
    return vec4<f32>(x, y, 0.0, 1.0);
}

@group(1) @binding(0) var t0: texture_2d<f32>;
@group(1) @binding(1) var t1: texture_2d<f32>;
@group(1) @binding(2) var t2: texture_2d<f32>;
@group(1) @binding(3) var t3: texture_2d<f32>;

fn load(t: texture_2d<f32>, p: vec2<i32>) -> f32 {
    let size = vec2<i32>(textureDimensions(t));
    return textureLoad(t, clamp(p, vec2<i32>(0), size - 1), 0).r;
}

// The narrow-range filter (Truong & Yuksel 2018), one direction of its separable form: a
// footprint of a fixed size in the world; samples more than mu behind the center are left
// out, samples more than mu in front are clamped to mu in front.
fn narrow_range(p: vec2<i32>, dir: vec2<i32>) -> f32 {
    let zc = load(t0, p);
    if (zc >= FAR) {
        return zc;
    }
    let r = min(i32(F.blur.x * F.screen.z / zc), i32(F.blur.z));
    if (r <= 0) {
        return zc;
    }
    let mu = F.blur.y;
    let inv_r = 1.0 / (f32(r) + 1.0);
    var sum = 0.0;
    var wsum = 0.0;
    for (var q = -r; q <= r; q = q + 1) {
        var z = load(t0, p + dir * q);
        if (z >= FAR || z > zc + mu) {
            continue;
        }
        z = max(z, zc - mu);
        let t = f32(q) * inv_r;
        let wgt = (1.0 - t * t) * (1.0 - t * t);
        sum = sum + wgt * z;
        wsum = wsum + wgt;
    }
    return select(zc, sum / wsum, wsum > 0.0);
}

@fragment
fn fs_smooth_x(@builtin(position) pos: vec4<f32>) -> @location(0) f32 {
    return narrow_range(vec2<i32>(pos.xy), vec2<i32>(1, 0));
}

@fragment
fn fs_smooth_y(@builtin(position) pos: vec4<f32>) -> @location(0) f32 {
    return narrow_range(vec2<i32>(pos.xy), vec2<i32>(0, 1));
}

// View-space point of pixel p at depth d.
fn view_point(p: vec2<i32>, d: f32) -> vec3<f32> {
    let c = 0.5 * F.screen.xy;
    let x = (f32(p.x) + 0.5 - c.x) / F.screen.z * d;
    let y = -(f32(p.y) + 0.5 - c.y) / F.screen.z * d;
    return vec3<f32>(x, y, -d);
}

// Of the two one-sided differences along a direction, the one with the smaller depth step
// (so silhouettes do not bend the normal).
fn side(p: vec2<i32>, s: vec2<i32>, centre: vec3<f32>, fallback: vec3<f32>) -> vec3<f32> {
    let da = load(t1, p + s);
    let db = load(t1, p - s);
    let a = view_point(p + s, da) - centre;
    let b = centre - view_point(p - s, db);
    let ok_a = da < FAR;
    let ok_b = db < FAR;
    if (ok_a && ok_b) {
        return select(b, a, abs(a.z) <= abs(b.z));
    }
    if (ok_a) {
        return a;
    }
    if (ok_b) {
        return b;
    }
    return fallback;
}

fn sky(r: vec3<f32>) -> vec3<f32> {
    let r_up = dot(r, F.up.xyz);
    let horizon = vec3<f32>(0.80, 0.87, 0.95);
    if (r_up >= 0.0) {
        return mix(horizon, vec3<f32>(0.36, 0.56, 0.86), sqrt(r_up));
    }
    return mix(horizon, vec3<f32>(0.32, 0.30, 0.27), min(sqrt(-r_up), 1.0));
}

// Fresnel (Schlick, F0 = 0.02) between the sky's reflection and the refracted scene behind
// (shifted along the normal by the thickness, absorbed per channel towards the deep colour);
// a sun highlight; foam on top.
@fragment
fn fs_composite(@builtin(position) pos: vec4<f32>) -> @location(0) vec4<f32> {
    let p = vec2<i32>(pos.xy);
    let scene = textureLoad(t0, p, 0);
    let foam = 0.9 * min(load(t3, p), 1.0);
    let foam_color = vec3<f32>(0.95, 0.97, 1.0);
    let d = load(t1, p);
    if (d >= FAR) {
        return vec4<f32>(mix(scene.rgb, foam_color, foam), 1.0);
    }
    let centre = view_point(p, d);
    let ddx = side(p, vec2<i32>(1, 0), centre, vec3<f32>(1.0, 0.0, 0.0));
    let ddy = side(p, vec2<i32>(0, 1), centre, vec3<f32>(0.0, -1.0, 0.0));
    var n = normalize(cross(ddy, ddx));
    if (n.z < 0.0) {
        n = -n;
    }
    let view = normalize(-centre);
    let cosv = clamp(dot(n, view), 0.0, 1.0);
    let fresnel = 0.02 + 0.98 * pow(1.0 - cosv, 5.0);
    let refl = sky(n * (2.0 * dot(n, view)) - view);
    let thick = load(t2, p);
    let shift = F.absorption.w * min(thick, 0.5) * F.screen.z / d;
    let size = vec2<i32>(textureDimensions(t0));
    let q = clamp(vec2<i32>(vec2<f32>(p) + vec2<f32>(n.x, -n.y) * shift), vec2<i32>(0), size - 1);
    let behind = textureLoad(t0, q, 0).rgb;
    let tr = exp(-F.absorption.xyz * thick / F.deep.w);
    let refr = behind * tr + F.deep.xyz * (1.0 - tr);
    let diffuse = 0.75 + 0.25 * max(dot(n, F.light.xyz), 0.0);
    var col = mix(refr * diffuse, refl, fresnel);
    let half_v = normalize(F.light.xyz + vec3<f32>(0.0, 0.0, 1.0));
    col = col + vec3<f32>(pow(max(dot(n, half_v), 0.0), 90.0) * 1.4);
    return vec4<f32>(mix(col, foam_color, foam), 1.0);
}
