// SPDX-License-Identifier: GPL-3.0-or-later
#version 330 core
// Animated wrinkle maps (Jimenez, Echevarria, Oat & Gutierrez 2011) as GLSL: the blend of
// Expression Wrinkles' wrinkle maps for a real-time engine.  docs/wrinkle_map_shaders.md
// explains the encodings, the zones and where the zone weights come from;
// wrinkle_addon/core/maps/jimenez.py (`blend`) is the reference this file follows line by
// line, and tests/core/test_shaders.py renders it and compares the two.
//
// Check it with glslang (Debian glslang-tools), from the repository's root:
//
//     glslangValidator -S frag docs/shaders/wrinkle_blend.glsl
//
// (tests/core/test_shader_commands.py runs that line as it is written here.)
//
// Use as an include: drop the `#version` line above (your shader has its own, 330 or
// later), `#define WRINKLE_BLEND_NO_MAIN` before the text, and call wrinkleBlend() (or
// the pieces) from your own fragment shader.  As it stands the file is a complete
// fragment shader (the `main` at the end).
//
// Conventions: every map and mask is linear (non-colour) data in [0, 1], sampled with
// nearest or bilinear filtering but never through an sRGB format; the tangent space is
// OpenGL's (+Y is +V, green up).  An engine with a -Y (DirectX) normal map convention
// flips the green of the base map before the blend and of the result after it (the doc).

#ifndef MAX_MAPS
#define MAX_MAPS 8
#endif

// jimenez._EPS: the smallest z of a base normal divided by, and the shortest length normalised
const float WRINKLE_EPS = 1e-6;

// --- encodings ---------------------------------------------------------------------------

// decode(c) = 2 c - 1
vec3 wrinkleDecode(vec3 c) { return 2.0 * c - 1.0; }
vec2 wrinkleDecode(vec2 c) { return 2.0 * c - 1.0; }

// encode(v) = 0.5 + 0.5 v
vec3 wrinkleEncode(vec3 v) { return 0.5 + 0.5 * v; }
vec2 wrinkleEncode(vec2 v) { return 0.5 + 0.5 * v; }

// jimenez.normalize: unit vector, (0, 0, 1) where the length is zero
vec3 wrinkleNormalize(vec3 v)
{
    float len = sqrt(dot(v, v));
    return len > WRINKLE_EPS ? v / max(len, WRINKLE_EPS) : vec3(0.0, 0.0, 1.0);
}

// jimenez.derivatives_of_normals: PD slopes n' = (n_x / n_z, n_y / n_z) of a unit normal,
// clipped to the 45 degree cone |n'_x|, |n'_y| <= 1; normals facing away clip to its edge
vec2 wrinkleDerivativesOfNormal(vec3 n)
{
    return clamp(n.xy / max(n.z, WRINKLE_EPS), -1.0, 1.0);
}

// jimenez.normals_of_derivatives: the unit normal of PD slopes, normalize(n'_x, n'_y, 1)
vec3 wrinkleNormalOfDerivatives(vec2 d) { return wrinkleNormalize(vec3(d, 1.0)); }

// jimenez.normal_to_derivative: standard normal map texel -> PD map texel (B = 0)
vec3 wrinkleNormalToDerivative(vec3 rgb)
{
    vec2 d = wrinkleDerivativesOfNormal(wrinkleNormalize(wrinkleDecode(rgb)));
    return vec3(wrinkleEncode(d), 0.0);
}

// jimenez.derivative_to_normal: PD map texel (only R and G are read) -> standard normal map texel
vec3 wrinkleDerivativeToNormal(vec3 rgb) { return wrinkleEncode(wrinkleNormalOfDerivatives(wrinkleDecode(rgb.xy))); }

// jimenez.difference_map: d = 0.5 + 0.5 (w - b) on the encoded RGB of two standard normal maps
vec3 wrinkleDifferenceMap(vec3 baseRgb, vec3 wrinkleRgb) { return 0.5 + 0.5 * (wrinkleRgb - baseRgb); }

// --- the blend ---------------------------------------------------------------------------

// jimenez.mask_sum: sum_z mask_z * clamp(weight_z, 0, 1) over the 8 zones; mask A holds
// zones 1-4 in R, G, B, A and mask B zones 5-8, weightsA / weightsB the map's weights of
// the same zones.  The per-zone clamp is the paper's: a weight below 0 (an expression that
// cancels another) or above 1 never reaches the shading.
float wrinkleMaskSum(vec4 maskA, vec4 maskB, vec4 weightsA, vec4 weightsB)
{
    return dot(maskA, clamp(weightsA, 0.0, 1.0)) + dot(maskB, clamp(weightsB, 0.0, 1.0));
}

// The base normal map as PD slopes, converted in the shader so artists keep their
// standard base map: b.xy / max(b.z, eps), b = decode(base), neither normalised nor clipped
vec2 wrinkleBaseDerivative(vec3 baseRgb)
{
    vec3 b = wrinkleDecode(baseRgb);
    return b.xy / max(b.z, WRINKLE_EPS);
}

// One PD wrinkle map's share: d + s * decode(w'.rg), s = strength * mask sum
vec2 wrinkleAddDerivative(vec2 d, float s, vec3 mapRgb) { return d + s * wrinkleDecode(mapRgb.xy); }

// One difference map's share: n + s * 2 decode(d)
vec3 wrinkleAddDifference(vec3 n, float s, vec3 mapRgb) { return n + s * 2.0 * wrinkleDecode(mapRgb); }

// jimenez.blend at one texel: the unit tangent-space normal.  `weights` row k (8 floats
// from k * 8) holds map k's zone weights in zone order; maps from mapCount on are ignored.
//   PD:          n = normalize(b'_x + S sum_k s_k w'_kx,  b'_y + S sum_k s_k w'_ky,  1)
//   difference:  n = normalize(decode(b) + S sum_k s_k 2 decode(d_k))
vec3 wrinkleBlend(sampler2D baseMap, sampler2DArray wrinkleMaps, sampler2D maskAMap, sampler2D maskBMap,
                  vec2 uv, float weights[MAX_MAPS * 8], int mapCount, float strength, bool difference)
{
    vec3 baseRgb = texture(baseMap, uv).rgb;
    vec4 maskA = texture(maskAMap, uv);
    vec4 maskB = texture(maskBMap, uv);
    vec3 n = wrinkleDecode(baseRgb);
    vec2 d = wrinkleBaseDerivative(baseRgb);
    for (int k = 0; k < MAX_MAPS; ++k) {
        if (k >= mapCount)
            break;
        int row = k * 8;
        vec4 wA = vec4(weights[row + 0], weights[row + 1], weights[row + 2], weights[row + 3]);
        vec4 wB = vec4(weights[row + 4], weights[row + 5], weights[row + 6], weights[row + 7]);
        float s = strength * wrinkleMaskSum(maskA, maskB, wA, wB);
        vec3 mapRgb = texture(wrinkleMaps, vec3(uv, float(k))).rgb;
        if (difference)
            n = wrinkleAddDifference(n, s, mapRgb);
        else
            d = wrinkleAddDerivative(d, s, mapRgb);
    }
    return difference ? wrinkleNormalize(n) : wrinkleNormalOfDerivatives(d);
}

// --- the standalone fragment shader ------------------------------------------------------

#ifndef WRINKLE_BLEND_NO_MAIN

uniform sampler2D baseMap;         // standard tangent-space normal map, RGB = 0.5 + 0.5 n
uniform sampler2DArray wrinkleMaps; // layer k = wrinkle map k (PD maps, or difference maps)
uniform sampler2D maskA;           // zones 1-4 in R, G, B, A
uniform sampler2D maskB;           // zones 5-8 in R, G, B, A
uniform float weights[MAX_MAPS * 8]; // row k = map k's 8 zone weights (CPU, per frame)
uniform int mapCount;              // wrinkle maps in use, 0 ... MAX_MAPS
uniform float strength;            // overall strength
uniform bool difference;           // false: PD maps; true: difference maps

in vec2 uv;

layout(location = 0) out vec4 fragColor;  // the normal encoded, 0.5 + 0.5 n (a normal map texel)
layout(location = 1) out vec4 fragNormal; // the unit normal itself (a float target keeps it exact)

void main()
{
    vec3 n = wrinkleBlend(baseMap, wrinkleMaps, maskA, maskB, uv, weights, mapCount, strength, difference);
    fragColor = vec4(wrinkleEncode(n), 1.0);
    fragNormal = vec4(n, 1.0);
}

#endif
