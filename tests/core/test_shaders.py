# SPDX-License-Identifier: GPL-3.0-or-later
"""The engine shaders of the wrinkle-map blend (docs/shaders/) against the NumPy reference.

Both files compile with glslang (the GLSL as it stands and as an include, the HLSL through
its SPIR-V back end), and both RUN: tests/core/glsl_runner.py draws the GLSL file, and the
GLSL that SPIRV-Cross makes of the HLSL's SPIR-V, with Mesa's llvmpipe (EGL with no
window, and OSMesa) into RGBA32F targets of the maps' size, and the normals read back must
be ``jimenez.blend``'s on the same inputs.  The inputs stand in for a head's maps: a noisy
base normal map, PD wrinkle maps of random furrows (steep enough that the 45 degree clip
bites), difference maps of the same, and soft random zone masks, 256 x 256; the zone
weights come from Table 1.1 through ``expression_sums`` and ``zone_response``, or are raw
(negative and above 1, for the per-zone clamp).  tests/blender/test_shaders_ict.py does the
same with the ICT head's baked maps.

Without glslangValidator, spirv-cross or a usable OpenGL the tests skip, or fail with
CI=true (tools/setup_system.sh installs them).
"""

import numpy as np
import pytest

from tests.core import glsl_runner as runner
from wrinkle_addon.core.maps import jimenez as wm

SIZE = 256
TOL = 1e-5  # float32 arithmetic in a different order: measured ~2e-7


def smooth_noise(rng, size, sigma):
    """White noise blurred by a Gaussian of ``sigma`` texels (periodic), unit deviation."""
    f = np.fft.fftfreq(size)
    fx, fy = np.meshgrid(f, f)
    g = np.exp(-2.0 * (np.pi * sigma) ** 2 * (fx**2 + fy**2))
    n = np.fft.ifft2(np.fft.fft2(rng.normal(size=(size, size))) * g).real
    return n / n.std()


def normals_of_heights(h):
    """Unit normals (H, W, 3) of a height field in texels, row 0 at v = 0."""
    dh_dv, dh_du = np.gradient(np.asarray(h, np.float64))
    return wm.normalize(np.dstack([-dh_du, -dh_dv, np.ones_like(h)]))


def base_heights(rng):
    """Pores and broad undulation: the base map's relief, in texels."""
    return 3.0 * smooth_noise(rng, SIZE, 8.0) + 0.25 * smooth_noise(rng, SIZE, 1.0)


def furrows(rng, n=14):
    """A sum of tapered furrows: straight grooves of random place, direction, length,
    width and depth, the deepest steeper than 45 degrees."""
    y, x = np.mgrid[0:SIZE, 0:SIZE] + 0.5
    h = np.zeros((SIZE, SIZE))
    for _ in range(n):
        cx, cy = rng.uniform(0.15, 0.85, 2) * SIZE
        theta = rng.uniform(0.0, np.pi)
        tx, ty = np.cos(theta), np.sin(theta)
        along = (x - cx) * tx + (y - cy) * ty
        across = -(x - cx) * ty + (y - cy) * tx
        half = rng.uniform(0.05, 0.2) * SIZE
        width = rng.uniform(1.5, 4.0)
        depth = rng.uniform(0.5, 5.0)
        taper = np.clip(1.0 - (along / half) ** 2, 0.0, 1.0) ** 2
        h -= depth * np.exp(-0.5 * (across / width) ** 2) * taper
    return h


def zone_masks(rng):
    """Masks A and B (H, W, 4): 8 soft blobs with wobbly borders, overlapping in places."""
    y, x = np.mgrid[0:SIZE, 0:SIZE] + 0.5
    zones = []
    for _ in range(wm.N_ZONES):
        cx, cy = rng.uniform(0.2, 0.8, 2) * SIZE
        r = rng.uniform(0.12, 0.3) * SIZE
        d = np.hypot(x - cx, y - cy) / r + 0.15 * smooth_noise(rng, SIZE, 12.0)
        t = np.clip((1.0 - d) / 0.4, 0.0, 1.0)
        zones.append(t * t * (3.0 - 2.0 * t))
    m = np.stack(zones, axis=-1).astype(np.float32)
    return m[..., :4], m[..., 4:]


def table_weights(values_per_map, zone_strength, zone_power):
    """Zone weights (K, 8) as an engine computes them per frame: for each map, the summed
    Table 1.1 rows of its expressions, then ``zone_response``."""
    rows = []
    for values in values_per_map:
        names = list(values)
        sums = wm.expression_sums([values[n] for n in names], [wm.TABLE_1_1[n] for n in names])
        rows.append(wm.zone_response(sums, zone_strength, zone_power))
    return np.array(rows, np.float32)


def make_cases():
    rng = np.random.default_rng(2011)
    hb = base_heights(rng)
    base = wm.encode(normals_of_heights(hb))
    heights = [furrows(rng) for _ in range(8)]
    pd = [wm.normal_to_derivative(wm.encode(normals_of_heights(h))) for h in heights]
    diff = [wm.difference_map(base, wm.encode(normals_of_heights(hb + h))) for h in heights[:2]]
    mask_a, mask_b = zone_masks(rng)
    strength_z = np.array([1.25] * 4 + [1.0] * 4, np.float32)
    power_z = rng.uniform(0.5, 2.0, 8).astype(np.float32)
    # two maps as the sample head has them: map 1 for Anger and Disgust, map 2 for the rest
    table = table_weights([{"Anger": 0.7, "Disgust": 0.4}, {"Surprise": 0.9, "Joy": 0.5, "Sad": 0.2}],
                          strength_z, power_z)
    raw = rng.choice([-0.7, 0.0, 0.3, 0.6, 1.0, 1.8], size=(3, 8)).astype(np.float32)
    eight = rng.uniform(-0.5, 1.5, (8, 8)).astype(np.float32)

    def case(maps, weights, strength, difference):
        return {"base": base, "maps": np.array(maps, np.float32).reshape(-1, SIZE, SIZE, 3),
                "mask_a": mask_a, "mask_b": mask_b, "weights": np.asarray(weights, np.float32).reshape(-1, 8),
                "strength": np.float32(strength), "difference": np.bool_(difference)}

    return {
        "pd_table": case(pd[:2], table, 1.0, False),
        "pd_clamp": case(pd[:3], raw, 0.8, False),
        "difference": case(diff, table, 1.3, True),
        "eight_maps": case(pd, eight, 0.6, False),
        "no_maps": case([], [], 1.0, False),
    }


def reference(case):
    return wm.blend(case["base"], list(case["maps"]), case["mask_a"], case["mask_b"], case["weights"],
                    float(case["strength"]), bool(case["difference"]))


@pytest.fixture(scope="module")
def cases():
    return make_cases()


def compare(cases, outputs):
    """Max abs differences {case: (normal, colour)}; asserts they are within TOL."""
    errors = {}
    for name, case in cases.items():
        want = reference(case)
        got = outputs[name]
        assert got["normal"].shape == want.shape
        errors[name] = (float(np.abs(got["normal"] - want).max()),
                        float(np.abs(got["color"] - wm.encode(want)).max()))
    print("max |GL - NumPy| (normal, colour):", errors)
    bad = {name: e for name, e in errors.items() if max(e) >= TOL}
    assert not bad, f"the shader's normals differ from jimenez.blend: {bad}"
    return errors


# --- the inputs are worth testing on -----------------------------------------------------------


def test_the_inputs_exercise_every_part_of_the_blend(cases):
    """So a shader that drops the clamp, the strength, a map or the mode cannot pass."""
    flat = wm.normalize(wm.decode(cases["no_maps"]["base"]))
    assert np.abs(flat[..., :2]).max() > 0.3  # a base with relief
    assert np.allclose(reference(cases["no_maps"]), flat, atol=1e-6)
    for name in ("pd_table", "pd_clamp", "difference", "eight_maps"):
        assert np.abs(reference(cases[name]) - flat).max() > 0.2, name  # the wrinkles show
    slopes = wm.decode(cases["pd_table"]["maps"][..., :2])
    assert (np.abs(slopes) > 0.999).mean() > 1e-3  # the 45 degree clip of the PD encoding bites
    for name in ("pd_table", "pd_clamp", "eight_maps"):  # zone weights above 1 (and below 0)
        case = cases[name]
        assert case["weights"].max() > 1.0, name
        assert np.abs(_blend_unclamped(case) - reference(case)).max() > 0.05, name
    assert cases["pd_clamp"]["weights"].min() < 0.0
    eight = cases["eight_maps"]
    seven = dict(eight, maps=eight["maps"][:7], weights=eight["weights"][:7])
    assert np.abs(reference(seven) - reference(eight)).max() > 0.05  # map 8 counts
    stronger = dict(cases["pd_clamp"], strength=np.float32(1.0))
    assert np.abs(reference(stronger) - reference(cases["pd_clamp"])).max() > 0.05  # the strength counts
    as_pd = dict(cases["difference"], difference=np.bool_(False))
    assert np.abs(reference(as_pd) - reference(cases["difference"])).max() > 0.05  # the mode counts


def _blend_unclamped(case):
    """jimenez.blend without the per-zone clamp above 1: what a shader that forgot it gives."""
    base = wm.decode(case["base"])
    d = base[..., :2] / np.maximum(base[..., 2:3], 1e-6)
    for w, m in zip(np.maximum(case["weights"], 0.0), case["maps"]):
        s = case["strength"] * (case["mask_a"] @ w[:4] + case["mask_b"] @ w[4:])
        d = d + s[..., None] * wm.decode(m[..., :2])
    return wm.normals_of_derivatives(d)


# --- compiling -------------------------------------------------------------------------------------


def test_glsl_compiles():
    runner.validate_glsl(runner.GLSL)
    assert runner.GLSL.read_text().splitlines()[1] == "#version 330 core"


def test_glsl_compiles_as_an_include(tmp_path):
    """The documented include: our own #version and main, WRINKLE_BLEND_NO_MAIN, the file
    without its #version line, and wrinkleBlend called with our own uniforms."""
    body = "\n".join(line for line in runner.GLSL.read_text().splitlines() if not line.startswith("#version"))
    shader = tmp_path / "include.frag"
    shader.write_text("\n".join([
        "#version 450", "#define WRINKLE_BLEND_NO_MAIN", "#define MAX_MAPS 4", body,
        "uniform sampler2D b, ma, mb; uniform sampler2DArray w; uniform float zw[MAX_MAPS * 8];",
        "in vec2 texCoord; out vec4 colour;",
        "void main()",
        "{ colour = vec4(wrinkleEncode(wrinkleBlend(b, w, ma, mb, texCoord, zw, 2, 1.0, false)), 1.0); }",
        ""]))
    runner.validate_glsl(shader)


def test_hlsl_compiles(tmp_path):
    runner.validate_hlsl(runner.HLSL, tmp_path / "wrinkle_blend.spv")
    assert (tmp_path / "wrinkle_blend.spv").stat().st_size > 0


def test_hlsl_compiles_as_an_include(tmp_path):
    shader = tmp_path / "include.hlsl"
    shader.write_text("\n".join([
        "#define WRINKLE_BLEND_NO_MAIN", "#define MAX_MAPS 4", '#include "wrinkle_blend.hlsl"',
        "Texture2D b; Texture2D ma; Texture2D mb; Texture2DArray w; SamplerState s;",
        "cbuffer Zones { float4 zw[MAX_MAPS * 2]; };",
        "float4 main(float2 uv : TEXCOORD0) : SV_Target",
        "{ return float4(wrinkleEncode(wrinkleBlend(b, w, ma, mb, s, uv, zw, 2, 1.0, false)), 1.0); }", ""]))
    runner.validate_hlsl(shader, tmp_path / "include.spv", include_dirs=[runner.HLSL.parent])


# --- running ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("api", ["egl", "osmesa"])
def test_glsl_renders_the_numpy_blend(cases, tmp_path, api):
    info, outputs = runner.render(runner.GLSL, cases, tmp_path, api=api)
    print(info)
    compare(cases, outputs)


def test_hlsl_renders_the_numpy_blend(cases, tmp_path):
    shader = runner.glsl_of_hlsl(runner.HLSL, tmp_path)
    info, outputs = runner.render(shader, cases, tmp_path)
    print(info)
    compare(cases, outputs)


def test_a_wrong_shader_fails_the_comparison(cases, tmp_path):
    """The comparison can fail: the GLSL with its per-zone clamp taken out renders what
    _blend_unclamped computes, not jimenez.blend."""
    text = runner.GLSL.read_text()
    clamp = "dot(maskA, clamp(weightsA, 0.0, 1.0)) + dot(maskB, clamp(weightsB, 0.0, 1.0))"
    assert clamp in text
    broken = tmp_path / "broken.glsl"
    broken.write_text(text.replace(clamp, "dot(maskA, max(weightsA, 0.0)) + dot(maskB, max(weightsB, 0.0))"))
    subset = {name: cases[name] for name in ("pd_clamp",)}
    _info, outputs = runner.render(broken, subset, tmp_path)
    with pytest.raises(AssertionError, match="differ from jimenez.blend"):
        compare(subset, outputs)
    assert np.abs(outputs["pd_clamp"]["normal"] - _blend_unclamped(subset["pd_clamp"])).max() < TOL


def test_the_doc_quotes_the_shaders_as_they_are():
    """Every code line of docs/wrinkle_map_shaders.md's GLSL and HLSL blocks is a line of
    the shader file (comments aside), so the listings cannot drift from the files."""
    import re

    doc = (runner.ROOT / "docs" / "wrinkle_map_shaders.md").read_text()

    def code(line):
        return " ".join(line.split("//")[0].split())

    for language, path in (("glsl", runner.GLSL), ("hlsl", runner.HLSL)):
        blocks = re.findall(rf"```{language}\n(.*?)```", doc, re.S)
        assert blocks, language
        lines = {code(line) for line in path.read_text().splitlines()}
        quoted = [code(line) for block in blocks for line in block.splitlines() if code(line)]
        missing = [line for line in quoted if line not in lines]
        assert not missing, f"{path.name}: the doc quotes lines the file does not have: {missing}"
