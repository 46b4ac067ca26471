# SPDX-License-Identifier: GPL-3.0-or-later
"""Render the wrinkle-map blend fragment shader on this machine's OpenGL, with ctypes only.

    python tests/core/glsl_runner.py [--api auto|egl|osmesa] SHADER.glsl CASE.npz [CASE.npz ...]

``SHADER.glsl`` is docs/shaders/wrinkle_blend.glsl, or the GLSL that SPIRV-Cross makes of
docs/shaders/wrinkle_blend.hlsl (its samplers are then ``SPIRV_Cross_Combined<texture>
mapSampler`` and its constants the std140 uniform block ``WrinkleBlend``; both are found
by name).  Each ``CASE.npz`` holds the inputs of one draw:

    base (H, W, >=3), maps (K, H, W, >=3), mask_a, mask_b (H, W, 4), weights (K, 8),
    strength (), difference ()   -- float32 images, row 0 at v = 0 (Blender's order)

Every image goes up as an RGBA32F texture with nearest filtering; a full-screen quad is
drawn into two RGBA32F colour attachments of the maps' size (outputs 0 and 1 of the
shader: the encoded colour and the unit normal), read back with glReadPixels, row 0 at
the bottom, which is v = 0 again.  The results go to ``CASE.out.npz`` (``normal`` and
``color``, (H, W, 3)).  The first line printed is JSON: the API and the GL strings.

The context is Mesa's software renderer, llvmpipe (``LIBGL_ALWAYS_SOFTWARE=1``), through EGL
with no window (``EGL_MESA_platform_surfaceless``) or else OSMesa; ``--api`` picks one.
Exit status 0: done; 77: no usable OpenGL here (the message says why); 1: anything else,
e.g. a shader that does not compile.  tests/core/test_shaders.py and
tests/blender/test_shaders_ict.py run this in a child process (:func:`render`, with the
same interpreter) so that a crash in the driver cannot take pytest down; the helpers at the
end of the file (glslang, SPIRV-Cross, skip or fail when a tool is missing) are theirs.
"""

import argparse
import ctypes
import json
import os
import sys
from pathlib import Path

import numpy as np

NO_GL = 77
MAX_MAPS = 8
N_ZONES = 8

# OpenGL enums
GL_TEXTURE_2D = 0x0DE1
GL_TEXTURE_2D_ARRAY = 0x8C1A
GL_TEXTURE0 = 0x84C0
GL_TEXTURE_MIN_FILTER = 0x2801
GL_TEXTURE_MAG_FILTER = 0x2800
GL_TEXTURE_WRAP_S = 0x2802
GL_TEXTURE_WRAP_T = 0x2803
GL_NEAREST = 0x2600
GL_CLAMP_TO_EDGE = 0x812F
GL_RGBA = 0x1908
GL_RGBA32F = 0x8814
GL_FLOAT = 0x1406
GL_FRAMEBUFFER = 0x8D40
GL_FRAMEBUFFER_COMPLETE = 0x8CD5
GL_COLOR_ATTACHMENT0 = 0x8CE0
GL_FRAGMENT_SHADER = 0x8B30
GL_VERTEX_SHADER = 0x8B31
GL_COMPILE_STATUS = 0x8B81
GL_LINK_STATUS = 0x8B82
GL_INFO_LOG_LENGTH = 0x8B84
GL_TRIANGLE_STRIP = 0x0005
GL_VENDOR = 0x1F00
GL_RENDERER = 0x1F01
GL_VERSION = 0x1F02
GL_SHADING_LANGUAGE_VERSION = 0x8B8C
GL_UNIFORM_BUFFER = 0x8A11
GL_STATIC_DRAW = 0x88E4
GL_INVALID_INDEX = 0xFFFFFFFF
GL_PACK_ALIGNMENT = 0x0D05
GL_UNPACK_ALIGNMENT = 0x0CF5

# EGL enums
EGL_PLATFORM_SURFACELESS_MESA = 0x31DD
EGL_EXTENSIONS = 0x3055
EGL_NONE = 0x3038
EGL_OPENGL_API = 0x30A2
EGL_CONTEXT_MAJOR_VERSION = 0x3098
EGL_CONTEXT_MINOR_VERSION = 0x30FB
EGL_CONTEXT_OPENGL_PROFILE_MASK = 0x30FD
EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT = 0x1

# OSMesa enums
OSMESA_FORMAT = 0x22
OSMESA_DEPTH_BITS = 0x30
OSMESA_STENCIL_BITS = 0x31
OSMESA_ACCUM_BITS = 0x32
OSMESA_PROFILE = 0x33
OSMESA_CORE_PROFILE = 0x34
OSMESA_CONTEXT_MAJOR_VERSION = 0x36
OSMESA_CONTEXT_MINOR_VERSION = 0x37
GL_UNSIGNED_BYTE = 0x1401

VERTEX_330 = """#version 330 core
out vec2 uv;
void main()
{
    vec2 p = vec2(float(gl_VertexID & 1), float(gl_VertexID >> 1));  // the quad as a strip
    uv = p;
    gl_Position = vec4(2.0 * p - 1.0, 0.0, 1.0);
}
"""
# SPIRV-Cross gives the fragment inputs locations: the vertex outputs need them too
VERTEX_450 = VERTEX_330.replace("#version 330 core", "#version 450").replace(
    "out vec2 uv;", "layout(location = 0) out vec2 uv;")

c_uint_p = ctypes.POINTER(ctypes.c_uint)

# name: (result, argument types)
GL_FUNCTIONS = {
    "glGetString": (ctypes.c_char_p, [ctypes.c_uint]),
    "glGetError": (ctypes.c_uint, []),
    "glCreateShader": (ctypes.c_uint, [ctypes.c_uint]),
    "glShaderSource": (None, [ctypes.c_uint, ctypes.c_int, ctypes.POINTER(ctypes.c_char_p), ctypes.c_void_p]),
    "glCompileShader": (None, [ctypes.c_uint]),
    "glGetShaderiv": (None, [ctypes.c_uint, ctypes.c_uint, ctypes.POINTER(ctypes.c_int)]),
    "glGetShaderInfoLog": (None, [ctypes.c_uint, ctypes.c_int, ctypes.c_void_p, ctypes.c_char_p]),
    "glCreateProgram": (ctypes.c_uint, []),
    "glAttachShader": (None, [ctypes.c_uint, ctypes.c_uint]),
    "glLinkProgram": (None, [ctypes.c_uint]),
    "glGetProgramiv": (None, [ctypes.c_uint, ctypes.c_uint, ctypes.POINTER(ctypes.c_int)]),
    "glGetProgramInfoLog": (None, [ctypes.c_uint, ctypes.c_int, ctypes.c_void_p, ctypes.c_char_p]),
    "glUseProgram": (None, [ctypes.c_uint]),
    "glGetUniformLocation": (ctypes.c_int, [ctypes.c_uint, ctypes.c_char_p]),
    "glGetUniformBlockIndex": (ctypes.c_uint, [ctypes.c_uint, ctypes.c_char_p]),
    "glUniformBlockBinding": (None, [ctypes.c_uint, ctypes.c_uint, ctypes.c_uint]),
    "glUniform1i": (None, [ctypes.c_int, ctypes.c_int]),
    "glUniform1f": (None, [ctypes.c_int, ctypes.c_float]),
    "glUniform1fv": (None, [ctypes.c_int, ctypes.c_int, ctypes.c_void_p]),
    "glGenBuffers": (None, [ctypes.c_int, c_uint_p]),
    "glBindBuffer": (None, [ctypes.c_uint, ctypes.c_uint]),
    "glBufferData": (None, [ctypes.c_uint, ctypes.c_ssize_t, ctypes.c_void_p, ctypes.c_uint]),
    "glBindBufferBase": (None, [ctypes.c_uint, ctypes.c_uint, ctypes.c_uint]),
    "glGenTextures": (None, [ctypes.c_int, c_uint_p]),
    "glBindTexture": (None, [ctypes.c_uint, ctypes.c_uint]),
    "glActiveTexture": (None, [ctypes.c_uint]),
    "glTexParameteri": (None, [ctypes.c_uint, ctypes.c_uint, ctypes.c_int]),
    "glTexImage2D": (None, [ctypes.c_uint, ctypes.c_int, ctypes.c_int, ctypes.c_int, ctypes.c_int,
                            ctypes.c_int, ctypes.c_uint, ctypes.c_uint, ctypes.c_void_p]),
    "glTexImage3D": (None, [ctypes.c_uint, ctypes.c_int, ctypes.c_int, ctypes.c_int, ctypes.c_int,
                            ctypes.c_int, ctypes.c_int, ctypes.c_uint, ctypes.c_uint, ctypes.c_void_p]),
    "glPixelStorei": (None, [ctypes.c_uint, ctypes.c_int]),
    "glGenFramebuffers": (None, [ctypes.c_int, c_uint_p]),
    "glBindFramebuffer": (None, [ctypes.c_uint, ctypes.c_uint]),
    "glFramebufferTexture2D": (None, [ctypes.c_uint, ctypes.c_uint, ctypes.c_uint, ctypes.c_uint,
                                      ctypes.c_int]),
    "glCheckFramebufferStatus": (ctypes.c_uint, [ctypes.c_uint]),
    "glDrawBuffers": (None, [ctypes.c_int, c_uint_p]),
    "glReadBuffer": (None, [ctypes.c_uint]),
    "glReadPixels": (None, [ctypes.c_int, ctypes.c_int, ctypes.c_int, ctypes.c_int, ctypes.c_uint,
                            ctypes.c_uint, ctypes.c_void_p]),
    "glViewport": (None, [ctypes.c_int, ctypes.c_int, ctypes.c_int, ctypes.c_int]),
    "glGenVertexArrays": (None, [ctypes.c_int, c_uint_p]),
    "glBindVertexArray": (None, [ctypes.c_uint]),
    "glDrawArrays": (None, [ctypes.c_uint, ctypes.c_int, ctypes.c_int]),
    "glFinish": (None, []),
}


class NoGL(Exception):
    """No usable OpenGL context here; the message says why."""


class GL:
    """The GL functions, looked up through the context API's GetProcAddress."""

    def __init__(self, get_proc_address):
        for name, (restype, argtypes) in GL_FUNCTIONS.items():
            address = get_proc_address(name.encode())
            if not address:
                raise NoGL(f"the GL function {name} is missing")
            setattr(self, name[2:], ctypes.CFUNCTYPE(restype, *argtypes)(address))

    def check(self, what):
        err = self.GetError()
        if err:
            raise RuntimeError(f"GL error 0x{err:04X} after {what}")

    def string(self, name):
        s = self.GetString(name)
        return s.decode() if s else ""


def _library(names):
    for name in names:
        try:
            return ctypes.CDLL(name)
        except OSError:
            continue
    raise NoGL(f"none of the libraries {', '.join(names)} loads (Debian: libegl-mesa0, libosmesa6)")


def egl_context():
    """A core 3.3 context on EGL's surfaceless platform (no window, no display)."""
    egl = _library(["libEGL.so.1", "libEGL.so"])
    egl.eglGetProcAddress.restype = ctypes.c_void_p
    egl.eglGetProcAddress.argtypes = [ctypes.c_char_p]
    egl.eglQueryString.restype = ctypes.c_char_p
    egl.eglQueryString.argtypes = [ctypes.c_void_p, ctypes.c_int]
    client = (egl.eglQueryString(None, EGL_EXTENSIONS) or b"").decode()
    if "EGL_MESA_platform_surfaceless" not in client:
        raise NoGL(f"EGL has no EGL_MESA_platform_surfaceless (client extensions: {client or 'none'})")
    address = egl.eglGetProcAddress(b"eglGetPlatformDisplayEXT")
    if not address:
        raise NoGL("EGL has no eglGetPlatformDisplayEXT")
    get_display = ctypes.CFUNCTYPE(ctypes.c_void_p, ctypes.c_uint, ctypes.c_void_p,
                                   ctypes.POINTER(ctypes.c_int))(address)
    display = get_display(EGL_PLATFORM_SURFACELESS_MESA, None, None)
    if not display:
        raise NoGL("eglGetPlatformDisplayEXT(surfaceless) gave no display")
    major, minor = ctypes.c_int(), ctypes.c_int()
    egl.eglInitialize.argtypes = [ctypes.c_void_p, ctypes.POINTER(ctypes.c_int), ctypes.POINTER(ctypes.c_int)]
    if not egl.eglInitialize(display, ctypes.byref(major), ctypes.byref(minor)):
        raise NoGL("eglInitialize failed on the surfaceless platform (Debian: libgl1-mesa-dri)")
    egl.eglBindAPI.argtypes = [ctypes.c_uint]
    if not egl.eglBindAPI(EGL_OPENGL_API):
        raise NoGL("eglBindAPI(EGL_OPENGL_API) failed")
    attribs = (ctypes.c_int * 7)(EGL_CONTEXT_MAJOR_VERSION, 3, EGL_CONTEXT_MINOR_VERSION, 3,
                                 EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                                 EGL_NONE)
    egl.eglCreateContext.restype = ctypes.c_void_p
    egl.eglCreateContext.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p]
    # EGL_KHR_no_config_context: no config, as nothing is ever drawn to an EGL surface
    context = egl.eglCreateContext(display, None, None, attribs)
    if not context:
        raise NoGL("eglCreateContext(OpenGL 3.3 core, no config) failed")
    egl.eglMakeCurrent.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p]
    if not egl.eglMakeCurrent(display, None, None, context):  # EGL_KHR_surfaceless_context
        raise NoGL("eglMakeCurrent with no surface failed")
    return GL(egl.eglGetProcAddress), f"EGL {major.value}.{minor.value} surfaceless", (egl, display, context)


def osmesa_context():
    """A core 3.3 context of OSMesa (off-screen Mesa) on a small client-side buffer."""
    lib = _library(["libOSMesa.so.8", "libOSMesa.so.6", "libOSMesa.so"])
    lib.OSMesaGetProcAddress.restype = ctypes.c_void_p
    lib.OSMesaGetProcAddress.argtypes = [ctypes.c_char_p]
    lib.OSMesaCreateContextAttribs.restype = ctypes.c_void_p
    lib.OSMesaCreateContextAttribs.argtypes = [ctypes.POINTER(ctypes.c_int), ctypes.c_void_p]
    attribs = (ctypes.c_int * 15)(OSMESA_FORMAT, GL_RGBA, OSMESA_DEPTH_BITS, 0, OSMESA_STENCIL_BITS, 0,
                                  OSMESA_ACCUM_BITS, 0, OSMESA_PROFILE, OSMESA_CORE_PROFILE,
                                  OSMESA_CONTEXT_MAJOR_VERSION, 3, OSMESA_CONTEXT_MINOR_VERSION, 3, 0)
    context = lib.OSMesaCreateContextAttribs(attribs, None)
    if not context:
        raise NoGL("OSMesaCreateContextAttribs(OpenGL 3.3 core) failed")
    buffer = (ctypes.c_ubyte * (4 * 4 * 4))()  # the window-system buffer: 4 x 4, never read
    lib.OSMesaMakeCurrent.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_uint, ctypes.c_int,
                                      ctypes.c_int]
    if not lib.OSMesaMakeCurrent(context, buffer, GL_UNSIGNED_BYTE, 4, 4):
        raise NoGL("OSMesaMakeCurrent failed")
    return GL(lib.OSMesaGetProcAddress), "OSMesa", (lib, context, buffer)


def make_context(api):
    makers = {"egl": [egl_context], "osmesa": [osmesa_context], "auto": [egl_context, osmesa_context]}[api]
    reasons = []
    for make in makers:
        try:
            return make()
        except NoGL as exc:
            reasons.append(f"{make.__name__}: {exc}")
    raise NoGL("; ".join(reasons))


# --- drawing ---------------------------------------------------------------------------------


def _compile(gl, kind, source):
    shader = gl.CreateShader(kind)
    src = ctypes.c_char_p(source.encode())
    gl.ShaderSource(shader, 1, ctypes.byref(src), None)
    gl.CompileShader(shader)
    ok = ctypes.c_int()
    gl.GetShaderiv(shader, GL_COMPILE_STATUS, ctypes.byref(ok))
    if not ok.value:
        log = ctypes.create_string_buffer(1 << 16)
        gl.GetShaderInfoLog(shader, len(log), None, log)
        stage = "vertex" if kind == GL_VERTEX_SHADER else "fragment"
        raise RuntimeError(f"the {stage} shader does not compile:\n{log.value.decode(errors='replace')}")
    return shader


def program(gl, fragment_source):
    first = next(line for line in fragment_source.splitlines() if line.startswith("#version"))
    vertex = VERTEX_330 if int(first.split()[1]) < 410 else VERTEX_450
    prog = gl.CreateProgram()
    gl.AttachShader(prog, _compile(gl, GL_VERTEX_SHADER, vertex))
    gl.AttachShader(prog, _compile(gl, GL_FRAGMENT_SHADER, fragment_source))
    gl.LinkProgram(prog)
    ok = ctypes.c_int()
    gl.GetProgramiv(prog, GL_LINK_STATUS, ctypes.byref(ok))
    if not ok.value:
        log = ctypes.create_string_buffer(1 << 16)
        gl.GetProgramInfoLog(prog, len(log), None, log)
        raise RuntimeError(f"the program does not link:\n{log.value.decode(errors='replace')}")
    return prog


def _rgba(image):
    image = np.asarray(image, np.float32)
    out = np.ones(image.shape[:-1] + (4,), np.float32)
    out[..., : min(4, image.shape[-1])] = image[..., :4]
    return np.ascontiguousarray(out)


def _texture(gl, unit, target, image):
    tex = ctypes.c_uint()
    gl.GenTextures(1, ctypes.byref(tex))
    gl.ActiveTexture(GL_TEXTURE0 + unit)
    gl.BindTexture(target, tex.value)
    for pname, value in ((GL_TEXTURE_MIN_FILTER, GL_NEAREST), (GL_TEXTURE_MAG_FILTER, GL_NEAREST),
                         (GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE), (GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE)):
        gl.TexParameteri(target, pname, value)
    data = _rgba(image)
    if target == GL_TEXTURE_2D_ARRAY:
        layers, h, w = data.shape[:3]
        gl.TexImage3D(target, 0, GL_RGBA32F, w, h, layers, 0, GL_RGBA, GL_FLOAT, data.ctypes.data)
    else:
        h, w = data.shape[:2]
        gl.TexImage2D(target, 0, GL_RGBA32F, w, h, 0, GL_RGBA, GL_FLOAT, data.ctypes.data)
    gl.check(f"uploading texture unit {unit}")
    return tex.value


def _sampler_location(gl, prog, name):
    for candidate in (name, f"SPIRV_Cross_Combined{name}mapSampler"):
        loc = gl.GetUniformLocation(prog, candidate.encode())
        if loc >= 0:
            return loc
    raise RuntimeError(f"the shader has no sampler {name!r}")


def _set_constants(gl, prog, weights, map_count, strength, difference):
    """Plain uniforms (the GLSL file) or the std140 block WrinkleBlend (the HLSL's cbuffer)."""
    block = gl.GetUniformBlockIndex(prog, b"WrinkleBlend")
    if block != GL_INVALID_INDEX:
        # float4 weights[16] (bytes 0-255), int mapCount (256), float strength (260), bool difference (264)
        data = np.zeros(272 // 4, np.float32)
        data[: MAX_MAPS * N_ZONES] = weights
        data[65] = strength
        ints = data.view(np.int32)
        ints[64] = map_count
        ints[66] = int(difference)
        ubo = ctypes.c_uint()
        gl.GenBuffers(1, ctypes.byref(ubo))
        gl.BindBuffer(GL_UNIFORM_BUFFER, ubo.value)
        gl.BufferData(GL_UNIFORM_BUFFER, data.nbytes, data.ctypes.data, GL_STATIC_DRAW)
        gl.UniformBlockBinding(prog, block, 0)
        gl.BindBufferBase(GL_UNIFORM_BUFFER, 0, ubo.value)
        return
    locations = {}
    for name in ("weights", "mapCount", "strength", "difference"):
        loc = gl.GetUniformLocation(prog, name.encode())
        if loc < 0:
            loc = gl.GetUniformLocation(prog, f"{name}[0]".encode())
        if loc < 0:
            raise RuntimeError(f"the shader has no uniform {name!r}")
        locations[name] = loc
    gl.Uniform1fv(locations["weights"], MAX_MAPS * N_ZONES, weights.ctypes.data)
    gl.Uniform1i(locations["mapCount"], map_count)
    gl.Uniform1f(locations["strength"], strength)
    gl.Uniform1i(locations["difference"], int(difference))


def draw(gl, prog, case):
    """The shader's two outputs (normal, colour), (H, W, 3) each, for one case."""
    base = np.asarray(case["base"], np.float32)
    maps = np.asarray(case["maps"], np.float32)
    h, w = base.shape[:2]
    k = len(maps)
    if k > MAX_MAPS:
        raise ValueError(f"{k} wrinkle maps; the shader takes at most {MAX_MAPS}")
    if k == 0:
        maps = np.full((1, h, w, 4), 0.5, np.float32)  # a layer must exist; mapCount 0 reads none
    weights = np.zeros(MAX_MAPS * N_ZONES, np.float32)
    weights[: k * N_ZONES] = np.asarray(case["weights"], np.float32).reshape(-1)[: k * N_ZONES]

    gl.UseProgram(prog)
    gl.PixelStorei(GL_UNPACK_ALIGNMENT, 1)
    gl.PixelStorei(GL_PACK_ALIGNMENT, 1)
    textures = (("baseMap", GL_TEXTURE_2D, base), ("wrinkleMaps", GL_TEXTURE_2D_ARRAY, maps),
                ("maskA", GL_TEXTURE_2D, case["mask_a"]), ("maskB", GL_TEXTURE_2D, case["mask_b"]))
    for unit, (name, target, image) in enumerate(textures):
        _texture(gl, unit, target, image)
        gl.Uniform1i(_sampler_location(gl, prog, name), unit)
    _set_constants(gl, prog, weights, k, float(case["strength"]), bool(case["difference"]))
    gl.check("setting the uniforms")

    fbo = ctypes.c_uint()
    gl.GenFramebuffers(1, ctypes.byref(fbo))
    gl.BindFramebuffer(GL_FRAMEBUFFER, fbo.value)
    targets = []
    for i in range(2):
        tex = ctypes.c_uint()
        gl.GenTextures(1, ctypes.byref(tex))
        gl.ActiveTexture(GL_TEXTURE0 + 8 + i)
        gl.BindTexture(GL_TEXTURE_2D, tex.value)
        gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST)
        gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST)
        gl.TexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, w, h, 0, GL_RGBA, GL_FLOAT, None)
        gl.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0 + i, GL_TEXTURE_2D, tex.value, 0)
        targets.append(GL_COLOR_ATTACHMENT0 + i)
    status = gl.CheckFramebufferStatus(GL_FRAMEBUFFER)
    if status != GL_FRAMEBUFFER_COMPLETE:
        raise RuntimeError(f"the RGBA32F framebuffer is incomplete (0x{status:04X})")
    gl.DrawBuffers(2, (ctypes.c_uint * 2)(*targets))
    gl.Viewport(0, 0, w, h)
    vao = ctypes.c_uint()
    gl.GenVertexArrays(1, ctypes.byref(vao))
    gl.BindVertexArray(vao.value)
    gl.DrawArrays(GL_TRIANGLE_STRIP, 0, 4)
    gl.Finish()
    gl.check("drawing")

    out = {}
    for i, key in enumerate(("color", "normal")):  # location 0: colour, 1: normal
        gl.ReadBuffer(GL_COLOR_ATTACHMENT0 + i)
        pixels = np.empty((h, w, 4), np.float32)
        gl.ReadPixels(0, 0, w, h, GL_RGBA, GL_FLOAT, pixels.ctypes.data)
        out[key] = pixels[..., :3]
    gl.check("reading the pixels")
    return out


# --- for the tests: compile with glslang, run this file in a child process -------------------

ROOT = Path(__file__).resolve().parents[2]
GLSL = ROOT / "docs" / "shaders" / "wrinkle_blend.glsl"
HLSL = ROOT / "docs" / "shaders" / "wrinkle_blend.hlsl"
# what tools/setup_system.sh installs for these tests (Debian)
PACKAGES = "glslang-tools spirv-cross libosmesa6 libegl-mesa0 libgl1-mesa-dri"


def in_ci():
    return os.environ.get("CI", "").strip().lower() not in ("", "0", "false", "no")


def unavailable(reason):
    """Skip the test (outside CI) or fail it (CI=true, where tools/setup_system.sh must
    have installed everything)."""
    import pytest

    message = f"{reason}; bash tools/setup_system.sh installs it (apt-get install {PACKAGES})"
    if in_ci():
        pytest.fail(f"CI must be able to run the shaders: {message}", pytrace=False)
    pytest.skip(message)


def tool(name):
    """The path of the command-line tool ``name``, or skip / fail (:func:`unavailable`)."""
    import shutil

    path = shutil.which(name)
    if path is None:
        unavailable(f"{name} is not installed")
    return path


def _command(args, what):
    import subprocess

    done = subprocess.run(args, capture_output=True, text=True, timeout=600)
    if done.returncode != 0:
        raise AssertionError(f"{what} failed (exit {done.returncode}):\n$ {' '.join(map(str, args))}\n"
                             f"{done.stdout}{done.stderr}")
    return done


def validate_glsl(path):
    """glslangValidator on a GLSL fragment shader (its own #version decides the rules)."""
    return _command([tool("glslangValidator"), "-S", "frag", str(path)], f"glslangValidator on {path}")


def validate_hlsl(path, spirv, include_dirs=()):
    """glslangValidator on an HLSL pixel shader (entry point main): HLSL input (-D) must
    be compiled to SPIR-V (-V), written to ``spirv``."""
    args = [tool("glslangValidator"), "-D", "-V", "-S", "frag", "-e", "main"]
    args += [f"-I{d}" for d in include_dirs]
    return _command(args + ["-o", str(spirv), str(path)], f"glslangValidator -D on {path}")


def glsl_of_hlsl(path, folder):
    """The HLSL file as GLSL 4.50: glslang to SPIR-V, SPIRV-Cross back to GLSL."""
    folder = Path(folder)
    spirv = folder / "wrinkle_blend_hlsl.spv"
    validate_hlsl(path, spirv)
    out = folder / "wrinkle_blend_hlsl.glsl"
    _command([tool("spirv-cross"), "--version", "450", "--no-es", str(spirv), "--output", str(out)],
             "spirv-cross on the HLSL's SPIR-V")
    return out


def render(shader, cases, folder, api="auto"):
    """Run this file on ``shader`` for ``cases`` ({name: inputs}) in a child process of the
    same interpreter.  Returns (the GL strings, {name: {"normal", "color"}}).  No usable
    OpenGL skips or fails (:func:`unavailable`); a crash or error fails with its output."""
    import subprocess

    folder = Path(folder)
    paths = {}
    for name, case in cases.items():
        paths[name] = folder / f"{name}.npz"
        np.savez(paths[name], **{k: np.asarray(v) for k, v in case.items()})
    args = [sys.executable, str(Path(__file__).resolve()), "--api", api, str(shader)]
    args += [str(p) for p in paths.values()]
    done = subprocess.run(args, capture_output=True, text=True, timeout=600)
    if done.returncode == NO_GL:
        unavailable(done.stderr.strip() or "no usable OpenGL")
    if done.returncode != 0:
        rc = done.returncode
        how = f"died by signal {-rc}" if rc < 0 else f"exited with {rc}"
        raise AssertionError(f"the GL runner {how}:\n{done.stdout}{done.stderr}")
    info = json.loads(done.stdout.splitlines()[0])
    outputs = {}
    for name, path in paths.items():
        with np.load(path.with_suffix(".out.npz")) as out:
            outputs[name] = {key: out[key] for key in out.files}
    return info, outputs


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--api", choices=("auto", "egl", "osmesa"), default="auto")
    parser.add_argument("shader", type=Path)
    parser.add_argument("cases", type=Path, nargs="+")
    args = parser.parse_args(argv)
    # here, not at import: the tests import this module for the helpers below, and Blender
    # in the same process must keep its own GL settings
    os.environ.setdefault("LIBGL_ALWAYS_SOFTWARE", "1")
    os.environ.setdefault("EGL_PLATFORM", "surfaceless")
    try:
        gl, api, _keep = make_context(args.api)
    except NoGL as exc:
        print(f"no usable OpenGL: {exc}", file=sys.stderr)
        return NO_GL
    info = {"api": api, "vendor": gl.string(GL_VENDOR), "renderer": gl.string(GL_RENDERER),
            "version": gl.string(GL_VERSION), "glsl": gl.string(GL_SHADING_LANGUAGE_VERSION)}
    print(json.dumps(info), flush=True)
    prog = program(gl, args.shader.read_text())
    for path in args.cases:
        with np.load(path) as case:
            out = draw(gl, prog, {key: case[key] for key in case.files})
        np.savez(path.with_suffix(".out.npz"), **out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
