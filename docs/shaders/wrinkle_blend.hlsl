// SPDX-License-Identifier: GPL-3.0-or-later
// Animated wrinkle maps (Jimenez, Echevarria, Oat & Gutierrez 2011) as HLSL (Shader Model
// 4 or later): the blend of Expression Wrinkles' wrinkle maps for a real-time engine, the
// same functions as docs/shaders/wrinkle_blend.glsl.  docs/wrinkle_map_shaders.md
// explains the encodings, the zones and where the zone weights come from;
// wrinkle_addon/core/maps/jimenez.py (`blend`) is the reference this file follows line by
// line.  tests/core/test_shaders.py compiles it, translates it to GLSL through SPIR-V and
// renders it against the reference.
//
// Compile it with glslang (Debian glslang-tools), from the repository's root: HLSL input
// (-D) compiles only to SPIR-V (-V), here into wrinkle_blend.spv, entry point main:
//
//     glslangValidator -D -V -S frag -e main -o wrinkle_blend.spv docs/shaders/wrinkle_blend.hlsl
//
// (tests/core/test_shader_commands.py runs that line as it is written here.)
//
// Use as an include: `#define WRINKLE_BLEND_NO_MAIN` before `#include`-ing it, and call
// wrinkleBlend() (or the pieces) from your own pixel shader.  As it stands the file is a
// complete pixel shader (entry point `main`).
//
// Conventions: every map and mask is linear (non-colour) data in [0, 1], never bound
// through an sRGB view; the tangent space is OpenGL's (+Y is +V, green up).  A -Y
// (DirectX) engine flips the green of the base map before the blend and of the result
// after it (the doc).

#ifndef MAX_MAPS
#define MAX_MAPS 8
#endif

// jimenez._EPS: the smallest z of a base normal divided by, and the shortest length normalised
static const float WRINKLE_EPS = 1e-6;

// --- encodings ---------------------------------------------------------------------------

// decode(c) = 2 c - 1
float3 wrinkleDecode(float3 c) { return 2.0 * c - 1.0; }
float2 wrinkleDecode(float2 c) { return 2.0 * c - 1.0; }

// encode(v) = 0.5 + 0.5 v
float3 wrinkleEncode(float3 v) { return 0.5 + 0.5 * v; }
float2 wrinkleEncode(float2 v) { return 0.5 + 0.5 * v; }

// jimenez.normalize: unit vector, (0, 0, 1) where the length is zero
float3 wrinkleNormalize(float3 v)
{
    float len = sqrt(dot(v, v));
    return len > WRINKLE_EPS ? v / max(len, WRINKLE_EPS) : float3(0.0, 0.0, 1.0);
}

// jimenez.derivatives_of_normals: PD slopes n' = (n_x / n_z, n_y / n_z) of a unit normal,
// clipped to the 45 degree cone |n'_x|, |n'_y| <= 1; normals facing away clip to its edge
float2 wrinkleDerivativesOfNormal(float3 n)
{
    return clamp(n.xy / max(n.z, WRINKLE_EPS), -1.0, 1.0);
}

// jimenez.normals_of_derivatives: the unit normal of PD slopes, normalize(n'_x, n'_y, 1)
float3 wrinkleNormalOfDerivatives(float2 d) { return wrinkleNormalize(float3(d, 1.0)); }

// jimenez.normal_to_derivative: standard normal map texel -> PD map texel (B = 0)
float3 wrinkleNormalToDerivative(float3 rgb)
{
    float2 d = wrinkleDerivativesOfNormal(wrinkleNormalize(wrinkleDecode(rgb)));
    return float3(wrinkleEncode(d), 0.0);
}

// jimenez.derivative_to_normal: PD map texel (only R and G are read) -> standard normal map texel
float3 wrinkleDerivativeToNormal(float3 rgb) { return wrinkleEncode(wrinkleNormalOfDerivatives(wrinkleDecode(rgb.xy))); }

// jimenez.difference_map: d = 0.5 + 0.5 (w - b) on the encoded RGB of two standard normal maps
float3 wrinkleDifferenceMap(float3 baseRgb, float3 wrinkleRgb) { return 0.5 + 0.5 * (wrinkleRgb - baseRgb); }

// --- the blend ---------------------------------------------------------------------------

// jimenez.mask_sum: sum_z mask_z * clamp(weight_z, 0, 1) over the 8 zones; mask A holds
// zones 1-4 in R, G, B, A and mask B zones 5-8, weightsA / weightsB the map's weights of
// the same zones.  The per-zone clamp is the paper's: a weight below 0 (an expression that
// cancels another) or above 1 never reaches the shading.
float wrinkleMaskSum(float4 maskA, float4 maskB, float4 weightsA, float4 weightsB)
{
    return dot(maskA, saturate(weightsA)) + dot(maskB, saturate(weightsB));
}

// The base normal map as PD slopes, converted in the shader so artists keep their
// standard base map: b.xy / max(b.z, eps), b = decode(base), neither normalised nor clipped
float2 wrinkleBaseDerivative(float3 baseRgb)
{
    float3 b = wrinkleDecode(baseRgb);
    return b.xy / max(b.z, WRINKLE_EPS);
}

// One PD wrinkle map's share: d + s * decode(w'.rg), s = strength * mask sum
float2 wrinkleAddDerivative(float2 d, float s, float3 mapRgb) { return d + s * wrinkleDecode(mapRgb.xy); }

// One difference map's share: n + s * 2 decode(d)
float3 wrinkleAddDifference(float3 n, float s, float3 mapRgb) { return n + s * 2.0 * wrinkleDecode(mapRgb); }

// jimenez.blend at one texel: the unit tangent-space normal.  weights[2 k] holds map k's
// zones 1-4 and weights[2 k + 1] its zones 5-8 (the float4 rows a constant buffer packs
// anyway); maps from mapCount on are ignored.
//   PD:          n = normalize(b'_x + S sum_k s_k w'_kx,  b'_y + S sum_k s_k w'_ky,  1)
//   difference:  n = normalize(decode(b) + S sum_k s_k 2 decode(d_k))
float3 wrinkleBlend(Texture2D<float4> baseMap, Texture2DArray<float4> wrinkleMaps, Texture2D<float4> maskAMap,
                    Texture2D<float4> maskBMap, SamplerState samp, float2 uv, float4 weights[MAX_MAPS * 2],
                    int mapCount, float strength, bool difference)
{
    float3 baseRgb = baseMap.Sample(samp, uv).rgb;
    float4 maskA = maskAMap.Sample(samp, uv);
    float4 maskB = maskBMap.Sample(samp, uv);
    float3 n = wrinkleDecode(baseRgb);
    float2 d = wrinkleBaseDerivative(baseRgb);
    [loop]
    for (int k = 0; k < MAX_MAPS; ++k) {
        if (k >= mapCount)
            break;
        float s = strength * wrinkleMaskSum(maskA, maskB, weights[2 * k], weights[2 * k + 1]);
        float3 mapRgb = wrinkleMaps.Sample(samp, float3(uv, float(k))).rgb;
        if (difference)
            n = wrinkleAddDifference(n, s, mapRgb);
        else
            d = wrinkleAddDerivative(d, s, mapRgb);
    }
    return difference ? wrinkleNormalize(n) : wrinkleNormalOfDerivatives(d);
}

// --- the standalone pixel shader ---------------------------------------------------------

#ifndef WRINKLE_BLEND_NO_MAIN

Texture2D<float4> baseMap : register(t0);          // standard tangent-space normal map, RGB = 0.5 + 0.5 n
Texture2DArray<float4> wrinkleMaps : register(t1); // slice k = wrinkle map k (PD maps, or difference maps)
Texture2D<float4> maskA : register(t2);            // zones 1-4 in R, G, B, A
Texture2D<float4> maskB : register(t3);            // zones 5-8 in R, G, B, A
SamplerState mapSampler : register(s0);            // the same sampler for all (point or linear, clamp)

cbuffer WrinkleBlend : register(b0)
{
    float4 weights[MAX_MAPS * 2]; // map k: weights[2 k] = zones 1-4, weights[2 k + 1] = zones 5-8
    int mapCount;                 // wrinkle maps in use, 0 ... MAX_MAPS
    float strength;               // overall strength
    bool difference;              // false: PD maps; true: difference maps (4 bytes in a cbuffer)
};

struct WrinkleOut
{
    float4 color : SV_Target0;  // the normal encoded, 0.5 + 0.5 n (a normal map texel)
    float4 normal : SV_Target1; // the unit normal itself (a float target keeps it exact)
};

WrinkleOut main(float4 position : SV_Position, float2 uv : TEXCOORD0)
{
    float3 n = wrinkleBlend(baseMap, wrinkleMaps, maskA, maskB, mapSampler, uv, weights, mapCount, strength,
                            difference);
    WrinkleOut o;
    o.color = float4(wrinkleEncode(n), 1.0);
    o.normal = float4(n, 1.0);
    return o;
}

#endif
