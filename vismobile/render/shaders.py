"""GLSL that emulates the OpenGL ES 1.1 fixed pipeline, nothing more.

- Transform: gl_Position = projection * modelview * position (invariant, so the shaded and
  the item-buffer programs rasterise exactly the same pixels).
- GL_FIXED positions and normals arrive as int32 16.16 and are converted as the driver would.
- Lighting: the ES 1.1 lighting equation, evaluated per vertex (Gouraud), with
  GL_COLOR_MATERIAL (ambient = diffuse = vertex colour), no specular, one-sided lighting,
  three directional lights and the default scene ambient 0.2. No textures, no fog.
"""
from __future__ import annotations

import numpy as np

# World-space directions toward each light (normalised below), diffuse and ambient intensity.
LIGHT_DIRECTIONS = np.array([[0.4, 1.0, 0.6], [-0.7, 0.3, -0.2], [0.2, -0.5, -1.0]])
LIGHT_DIRECTIONS = LIGHT_DIRECTIONS / np.linalg.norm(LIGHT_DIRECTIONS, axis=1, keepdims=True)
LIGHT_DIFFUSE = np.array([0.75, 0.35, 0.2])
LIGHT_AMBIENT = np.array([0.05, 0.0, 0.0])
SCENE_AMBIENT = 0.2
CLEAR_RGB = (0.55, 0.62, 0.72)

_INPUTS = {
    "float32": "in vec3 in_position;\nvec3 position() { return in_position; }\n"
               "in vec3 in_normal;\nvec3 normal() { return in_normal; }\n",
    # GL_FIXED: value / 65536; the scale is a power of two, so only int->float rounds.
    "fixed16.16": "in ivec3 in_position;\nvec3 position() { return vec3(in_position) * "
                  "(1.0 / 65536.0); }\nin ivec3 in_normal;\nvec3 normal() { return "
                  "vec3(in_normal) * (1.0 / 65536.0); }\n",
}

_TRANSFORM = """
uniform mat4 u_mvp;
invariant gl_Position;
"""

# The fixed-function lighting (three directional lights and a scene ambient, per vertex), shared
# by the shaded and the textured vertex shaders: its uniforms, then the statements that place
# the vertex and light it into v_color.
LIGHT_UNIFORMS = """uniform vec3 u_light_dir[3];
uniform vec3 u_light_diffuse[3];
uniform vec3 u_light_ambient[3];
uniform float u_scene_ambient;
"""
LIT_VERTEX = """    gl_Position = u_mvp * vec4(position(), 1.0);
    vec3 n = normal();
    vec3 c = in_color.rgb * u_scene_ambient;
    for (int i = 0; i < 3; ++i) {{
        float diffuse = max(dot(n, u_light_dir[i]), 0.0);
        c += in_color.rgb * (u_light_ambient[i] + diffuse * u_light_diffuse[i]);
    }}
    v_color = vec4(clamp(c, 0.0, 1.0), in_color.a);
"""

SHADED_VERTEX = ("#version 330\n{inputs}{transform}\nin vec4 in_color;\n" + LIGHT_UNIFORMS
                 + "smooth out vec4 v_color;\nvoid main() {{\n" + LIT_VERTEX + "}}\n")

SHADED_FRAGMENT = """#version 330
smooth in vec4 v_color;
out vec4 f_color;
void main() { f_color = v_color; }
"""

# The shaded fragment with ES 1.1's alpha test, glAlphaFunc(GL_GREATER, 0.5): a terrain's
# no-data samples carry alpha 0, so the cut runs midway between a valid and a null vertex
# (seed 002's holes; render/terrain.py).
CUT_FRAGMENT = """#version 330
smooth in vec4 v_color;
out vec4 f_color;
void main() { if (v_color.a <= 0.5) discard; f_color = v_color; }
"""

# Item buffer: id + 1 of the triangle (vertex 3t+k belongs to triangle t), 0 = background.
ITEM_VERTEX = """#version 330
{inputs}{transform}
uniform uint u_first_id;
flat out uint v_id;
void main() {{
    gl_Position = u_mvp * vec4(position(), 1.0);
    v_id = u_first_id + uint(gl_VertexID / 3) + 1u;
}}
"""

ITEM_FRAGMENT = """#version 330
flat in uint v_id;
out uint f_id;
void main() { f_id = v_id; }
"""


# Overlays (viewer only, never timed): one flat colour, e.g. culled triangles or node boxes.
FLAT_VERTEX = """#version 330
{inputs}{transform}
void main() {{
    gl_Position = u_mvp * vec4(position(), 1.0);
}}
"""

FLAT_FRAGMENT = """#version 330
uniform vec4 u_color;
out vec4 f_color;
void main() { f_color = u_color; }
"""


def sources(kind: str, vertex_format: str) -> tuple:
    """(vertex, fragment) GLSL for kind "shaded", "cut" (shaded with the alpha test), "item"
    or "flat" and a vertex format."""
    inputs = _INPUTS[vertex_format]
    if kind in ("item", "flat"):
        # These programs read positions only; drop the unused normal input.
        inputs = inputs.split("in vec3 in_normal")[0].split("in ivec3 in_normal")[0]
        if kind == "flat":
            return FLAT_VERTEX.format(inputs=inputs, transform=_TRANSFORM), FLAT_FRAGMENT
        return ITEM_VERTEX.format(inputs=inputs, transform=_TRANSFORM), ITEM_FRAGMENT
    return SHADED_VERTEX.format(inputs=inputs, transform=_TRANSFORM), \
        CUT_FRAGMENT if kind == "cut" else SHADED_FRAGMENT
