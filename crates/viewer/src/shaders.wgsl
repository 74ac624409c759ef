// Scene shaders: filled triangles, pixel-wide segments (one instance each) and images, all in
// world metres mapped to clip space by one affine matrix.

struct Globals {
    // columns of the world -> clip affine map
    m0: vec4<f32>,
    m1: vec4<f32>,
    m2: vec4<f32>,
    // canvas size in pixels
    viewport: vec2<f32>,
    // 1 when the target stores linear colour (an *Srgb format)
    linear_target: u32,
    _pad: u32,
};

@group(0) @binding(0) var<uniform> g: Globals;

fn to_clip(p: vec2<f32>) -> vec2<f32> {
    return g.m0.xy * p.x + g.m1.xy * p.y + g.m2.xy;
}

// Colours arrive sRGB-encoded; a linear target needs them decoded.
fn out_color(c: vec4<f32>) -> vec4<f32> {
    if (g.linear_target == 1u) {
        let lo = c.rgb / 12.92;
        let hi = pow((c.rgb + 0.055) / 1.055, vec3<f32>(2.4));
        return vec4<f32>(select(hi, lo, c.rgb <= vec3<f32>(0.04045)), c.a);
    }
    return c;
}

struct ColorOut {
    @builtin(position) pos: vec4<f32>,
    @location(0) color: vec4<f32>,
};

@vertex
fn vs_fill(@location(0) pos: vec2<f32>, @location(1) color: vec4<f32>) -> ColorOut {
    var o: ColorOut;
    o.pos = vec4<f32>(to_clip(pos), 0.0, 1.0);
    o.color = out_color(color);
    return o;
}

@vertex
fn vs_segment(
    @builtin(vertex_index) vi: u32,
    @location(0) a: vec2<f32>,
    @location(1) b: vec2<f32>,
    @location(2) width: f32,
    @location(3) color: vec4<f32>,
) -> ColorOut {
    let ca = to_clip(a);
    let cb = to_clip(b);
    let half_vp = g.viewport * 0.5;
    // direction and normal in pixels
    var d = (cb - ca) * half_vp;
    let len = length(d);
    if (len < 1e-6) {
        d = vec2<f32>(1.0, 0.0);
    } else {
        d = d / len;
    }
    let n = vec2<f32>(-d.y, d.x);
    // two triangles: corners (end, side)
    var ends = array<f32, 6>(0.0, 1.0, 1.0, 0.0, 1.0, 0.0);
    var sides = array<f32, 6>(-1.0, -1.0, 1.0, -1.0, 1.0, 1.0);
    let t = ends[vi];
    let s = sides[vi];
    let base = mix(ca, cb, t);
    // half a pixel of cap at each end so short segments still show
    let along = (t * 2.0 - 1.0) * 0.5;
    let off_px = n * (s * width * 0.5) + d * along;
    var o: ColorOut;
    o.pos = vec4<f32>(base + off_px / half_vp, 0.0, 1.0);
    o.color = out_color(color);
    return o;
}

// Fills and segments take their colour already converted per vertex (the conversion is the
// same at every pixel of a single-coloured shape, and a software rasteriser pays for it per
// pixel).
@fragment
fn fs_color(i: ColorOut) -> @location(0) vec4<f32> {
    return i.color;
}

struct ImageOut {
    @builtin(position) pos: vec4<f32>,
    @location(0) uv: vec2<f32>,
};

@group(1) @binding(0) var image_tex: texture_2d<f32>;
@group(1) @binding(1) var image_sampler: sampler;

@vertex
fn vs_image(@location(0) pos: vec2<f32>, @location(1) uv: vec2<f32>) -> ImageOut {
    var o: ImageOut;
    o.pos = vec4<f32>(to_clip(pos), 0.0, 1.0);
    o.uv = uv;
    return o;
}

@fragment
fn fs_image(i: ImageOut) -> @location(0) vec4<f32> {
    return out_color(textureSample(image_tex, image_sampler, i.uv));
}

// The cached bottom layers: one quad over the whole viewport, texel for pixel, copied as stored
// (the cache is only used on targets whose stored values are final, so no colour conversion).
@vertex
fn vs_blit(@builtin(vertex_index) vi: u32) -> ImageOut {
    var xs = array<f32, 6>(-1.0, 1.0, 1.0, -1.0, 1.0, -1.0);
    var ys = array<f32, 6>(1.0, 1.0, -1.0, 1.0, -1.0, -1.0);
    var o: ImageOut;
    o.pos = vec4<f32>(xs[vi], ys[vi], 0.0, 1.0);
    o.uv = vec2<f32>((xs[vi] + 1.0) * 0.5, (1.0 - ys[vi]) * 0.5);
    return o;
}

@fragment
fn fs_blit(i: ImageOut) -> @location(0) vec4<f32> {
    return textureSample(image_tex, image_sampler, i.uv);
}

// Fans counted per pixel on the CPU (coverage.rs), each count already turned into the alpha
// that many blends of its colour reach (1 - (1 - a)^n): one channel per colour, composited in
// order and output premultiplied.

struct CoverageParams {
    // the colours as the target stores them (decoded to linear for an sRGB target)
    colors: array<vec4<f32>, 4>,
    // the alphas' size in texels (the viewport's in pixels)
    size: vec2<f32>,
    _pad: vec2<f32>,
};

@group(1) @binding(0) var coverage_alphas: texture_2d<f32>;
@group(1) @binding(1) var<uniform> coverage: CoverageParams;

fn coverage_texel(uv: vec2<f32>) -> vec2<i32> {
    return vec2<i32>(min(uv * coverage.size, coverage.size - vec2<f32>(1.0)));
}

// One colour (an R8 texture): the common case of one kind of ranger on show, kept to the
// least work per pixel, which a software rasteriser pays 900,000 times a frame.
@fragment
fn fs_coverage1(i: ImageOut) -> @location(0) vec4<f32> {
    let a = textureLoad(coverage_alphas, coverage_texel(i.uv), 0).r;
    return vec4<f32>(coverage.colors[0].rgb * a, a);
}

// Two colours (an RG8 texture), composited in order.
@fragment
fn fs_coverage2(i: ImageOut) -> @location(0) vec4<f32> {
    let alphas = textureLoad(coverage_alphas, coverage_texel(i.uv), 0);
    let o = vec4<f32>(coverage.colors[0].rgb * alphas.r, alphas.r);
    return vec4<f32>(coverage.colors[1].rgb * alphas.g, alphas.g) + o * (1.0 - alphas.g);
}

// Up to four colours (an RGBA8 texture; a channel not in use holds 0 and changes nothing).
@fragment
fn fs_coverage4(i: ImageOut) -> @location(0) vec4<f32> {
    let alphas = textureLoad(coverage_alphas, coverage_texel(i.uv), 0);
    var o = vec4<f32>(coverage.colors[0].rgb * alphas.r, alphas.r);
    o = vec4<f32>(coverage.colors[1].rgb * alphas.g, alphas.g) + o * (1.0 - alphas.g);
    o = vec4<f32>(coverage.colors[2].rgb * alphas.b, alphas.b) + o * (1.0 - alphas.b);
    o = vec4<f32>(coverage.colors[3].rgb * alphas.a, alphas.a) + o * (1.0 - alphas.a);
    return o;
}
