// Texture sampling by hand from the RGBA8 texel buffer: twin of src/texture.rs (same names; the
// wrap, filter and level-of-detail rules are written down there). Needs bindings.glsl.
#ifndef TEXTURE_GLSL
#define TEXTURE_GLSL
#include "scene_arrays.glsl"
#include "convert.glsl"

// The sRGB transfer function's inverse (IEC 61966-2-1), per channel.
float srgb_to_linear(float c) {
    return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4);
}

vec4 unpack_texel(uint word, bool srgb) {
    vec4 v = unpackUnorm4x8(word);
    if (srgb) v = vec4(srgb_to_linear(v.x), srgb_to_linear(v.y), srgb_to_linear(v.z), v.w);
    return v;
}

// A coordinate reduced to the range its wrap mode repeats over; non-finite reads as 0.
float reduce_coordinate(float u, uint mode) {
    if (isnan(u) || isinf(u)) return 0.0;
    if (mode == WRAP_CLAMP_TO_EDGE) return clamp(u, -1.0, 2.0);
    if (mode == WRAP_MIRRORED_REPEAT) return u - 2.0 * floor(0.5 * u);
    return u - floor(u);
}

// Texel index i (in [-n, 3n)) wrapped into [0, n) (Vulkan spec, "Wrapping Operation"). The
// remainders (i + n) mod n and (i + 2n) mod 2n by conditional subtractions, exact over that
// range: integer division is a `div` per lane on lavapipe and tens of cycles on a CPU.
int wrap_texel(int i, int n, uint mode) {
    if (mode == WRAP_CLAMP_TO_EDGE) return clamp(i, 0, n - 1);
    if (mode == WRAP_MIRRORED_REPEAT) {
        int j = i + 2 * n;  // in [n, 5n)
        j = j >= 2 * n ? j - 2 * n : j;
        j = j >= 2 * n ? j - 2 * n : j;
        return j >= n ? 2 * n - 1 - j : j;
    }
    int r = i + n;  // in [0, 4n)
    r = r >= n ? r - n : r;
    r = r >= n ? r - n : r;
    return r >= n ? r - n : r;
}

// Width, height and first texel of mip level `level`.
uvec3 texture_level(GpuTexture t, uint level) {
    uint w = t.width;
    uint h = t.height;
    uint offset = t.texel_offset;
    uint k = 0u;
    if (k < level) do {
        offset += w * h;
        w = max(w / 2u, 1u);
        h = max(h / 2u, 1u);
    } while (++k < level);
    return uvec3(w, h, offset);
}

vec4 texture_fetch(GpuTexture t, uint offset, uint w, int x, int y) {
    return unpack_texel(texel_at(offset + uint(y) * w + uint(x)), t.srgb != 0u);
}

// One mip level, nearest or bilinear. The texel reads are one loop, kept rolled: every texture
// a kernel samples then compiles to one read site (llvmpipe turns each site into eight per-lane
// loads, four times over in a scene whose texels span several bindings). The weights are those
// of src/texture.rs, in the same order.
vec4 texture_sample_level(GpuTexture t, uint level, vec2 uv, bool linear) {
    uvec3 l = texture_level(t, level);
    int wi = int(l.x);
    int hi = int(l.y);
    float x = reduce_coordinate(uv.x, t.wrap_s) * float(l.x);
    float y = reduce_coordinate(uv.y, t.wrap_t) * float(l.y);
    ivec2 i;  // columns of the taps
    ivec2 j;  // rows of the taps
    float fx = 0.0;
    float fy = 0.0;
    uint taps = 1u;
    if (!linear) {
        i = ivec2(wrap_texel(trunc_to_int(floor(x)), wi, t.wrap_s));
        j = ivec2(wrap_texel(trunc_to_int(floor(y)), hi, t.wrap_t));
    } else {
        x -= 0.5;
        y -= 0.5;
        float x0 = floor(x);
        float y0 = floor(y);
        fx = x - x0;
        fy = y - y0;
        ivec2 c0 = trunc_to_int(vec2(x0, y0));
        i = ivec2(wrap_texel(c0.x, wi, t.wrap_s), wrap_texel(c0.x + 1, wi, t.wrap_s));
        j = ivec2(wrap_texel(c0.y, hi, t.wrap_t), wrap_texel(c0.y + 1, hi, t.wrap_t));
        taps = 4u;
    }
    // (Named taps, not an array: llvmpipe keeps a dynamically indexed array in memory.)
    vec4 a = vec4(0.0);
    vec4 b = vec4(0.0);
    vec4 c = vec4(0.0);
    vec4 d = vec4(0.0);
    uint k = 0u;
    [[dont_unroll]] do {
        vec4 v = texture_fetch(t, l.z, l.x, (k & 1u) == 0u ? i.x : i.y, k < 2u ? j.x : j.y);
        if (k == 0u) a = v;
        else if (k == 1u) b = v;
        else if (k == 2u) c = v;
        else d = v;
    } while (++k < taps);
    if (taps == 1u) return a;
    vec4 top = a + (b - a) * fx;
    vec4 bottom = c + (d - c) * fx;
    return top + (bottom - top) * fy;
}

// lambda of a texture: lod_base + log2(w h |det M|) / 2.
float texture_lod(GpuTexture t, GpuTextureRef r, float lod_base) {
    float det = abs(r.transform.x * r.transform.w - r.transform.y * r.transform.z);
    return lod_base + 0.5 * log2(max(float(t.width) * float(t.height) * det, 1e-30));
}

// The texture at uv with level of detail lod (magnification where lod <= 0 or NaN): one or two
// levels, read by one rolled loop (see texture_sample_level).
vec4 texture_sample_lod(GpuTexture t, vec2 uv, float lod) {
    uint mag = t.filters & 15u;
    uint minf = (t.filters >> 4u) & 15u;
    uvec2 level = uvec2(0u);
    uint count = 1u;
    float f = 0.0;
    bool linear;
    if (isnan(lod) || lod <= 0.0) {
        linear = mag == FILTER_LINEAR;
    } else if (minf == MIN_NEAREST || minf == MIN_LINEAR) {
        linear = minf == MIN_LINEAR;
    } else {
        linear = minf == MIN_LINEAR_MIPMAP_NEAREST || minf == MIN_LINEAR_MIPMAP_LINEAR;
        float top = float(t.levels - 1u);
        if (minf == MIN_NEAREST_MIPMAP_NEAREST || minf == MIN_LINEAR_MIPMAP_NEAREST) {
            level.x = trunc_to_uint(min(floor(lod + 0.5), top));
        } else {
            float l0 = min(floor(lod), top);
            float l1 = min(l0 + 1.0, top);
            f = clamp(lod - l0, 0.0, 1.0);
            level = uvec2(trunc_to_int(vec2(l0, l1)));
            count = 2u;
        }
    }
    vec4 a = vec4(0.0);
    vec4 b = vec4(0.0);
    uint k = 0u;
    [[dont_unroll]] do {
        vec4 v = texture_sample_level(t, k == 0u ? level.x : level.y, uv, linear);
        if (k == 0u) a = v;
        else b = v;
    } while (++k < count);
    return count == 1u ? a : a + (b - a) * f;
}

// The coordinate a reference reads: its set, through its KHR_texture_transform.
vec2 texture_ref_uv(GpuTextureRef r, vec2 uv0, vec2 uv1) {
    vec2 st = r.texcoord == 1u ? uv1 : uv0;
    return vec2(r.transform.x * st.x + r.transform.y * st.y + r.offset.x,
                r.transform.z * st.x + r.transform.w * st.y + r.offset.y);
}

// A material's texture reference `index` at the coordinates of both sets.
vec4 sample_texture_ref(uint index, vec2 uv0, vec2 uv1, vec2 lod_base) {
    GpuTextureRef r = texture_ref_at(index);
    GpuTexture t = texture_at(r.texture);
    float base = r.texcoord == 1u ? lod_base.y : lod_base.x;
    return texture_sample_lod(t, texture_ref_uv(r, uv0, uv1), texture_lod(t, r, base));
}

#endif
