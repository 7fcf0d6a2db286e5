# SPDX-License-Identifier: GPL-3.0-or-later
"""The node program's vocabulary: opcodes, operand encodings and the int codes of Blender's
enum settings, shared by the compiler (node_program.py) and the interpreter
(gpu_shaders/include/node_program.glsl, whose ``#define``s must equal these numbers;
tests/test_node_program.py holds them together).

One instruction per node, in Cycles' SVM shape (words of 32 bits):

    header   opcode | outputs << 8 | settings << 16 | inputs << 24
    outputs  one register index per output value (a shader output: four), NO_REGISTER
             where nothing reads it
    settings one word per setting (an enum's code, an image layer, an int)
    inputs   one operand per input value (a shader input: four operands), each a register
             (REGISTER | conversion << 16), an inline constant (CONSTANT | n, then n float
             bit patterns) or a value of the shading point (IMPLICIT | code), which is how
             an unlinked Normal or Vector socket takes the surface's normal or coordinates
             as Blender's do.

Every value is a vec4 register; a shader (closure) value is four registers (node_program.glsl
``NodeClosure``). Enum codes of the node families written as pure GLSL
(``gpu_shaders/include/nodes/``) live here too, one dict per family.
"""
from __future__ import annotations

# Opcodes (node_program.glsl NODE_OP_*). 0 is never emitted: a zeroed word stops the program.
OP_OUTPUT = 1          # Material Output: the closure in, the program ends
OP_VALUE = 2           # Value and RGB: a constant through a register
OP_TEX_COORD = 3
OP_UVMAP = 4
OP_GEOMETRY = 5
OP_OBJECT_INFO = 6
OP_FRESNEL = 7
OP_LAYER_WEIGHT = 8
OP_LIGHT_PATH = 9
OP_SEPARATE_XYZ = 10
OP_COMBINE_XYZ = 11
OP_TEX_WHITE_NOISE = 12
OP_TEX_IMAGE = 13
OP_NORMAL_MAP = 14
OP_BSDF_PRINCIPLED = 32
OP_BSDF_DIFFUSE = 33
OP_BSDF_GLOSSY = 34
OP_BSDF_GLASS = 35
OP_BSDF_REFRACTION = 36
OP_BSDF_TRANSPARENT = 37
OP_EMISSION = 38
OP_MIX_SHADER = 39
OP_ADD_SHADER = 40
# -- colour and vector (opcodes 41-79)
OP_MATH = 41
OP_VECTOR_MATH = 42
OP_MIX = 43            # the Mix node: Float, Vector (uniform or not) and Color
OP_MIX_RGB = 44        # the legacy MixRGB node
OP_COLOR_RAMP = 45     # its table inline after the operands (RAMP_TABLE_WORDS)
OP_CURVE_RGB = 46      # tables inline after the operands (CURVE_TABLE_WORDS)
OP_CURVE_VECTOR = 47
OP_CURVE_FLOAT = 48
OP_HUE_SAT = 49
OP_INVERT = 50
OP_GAMMA = 51
OP_BRIGHT_CONTRAST = 52
OP_MAP_RANGE = 53
OP_CLAMP = 54
OP_SEPARATE_COLOR = 55
OP_COMBINE_COLOR = 56
OP_MAPPING = 57
OP_VECTOR_ROTATE = 58
# -- shading normals and bump (opcodes 60-69; block owned by the Bump / Normal Map work)
OP_BUMP_OFFSET = 60    # shifts the shading point by Filter Width x dP/dx or dP/dy (0: back)
OP_BUMP = 61           # Cycles' bump: the three heights into a perturbed normal
# -- attributes (opcodes 70-79): Color Attribute and Attribute, read from the scene's attribute
# store (hybrid_engine/scene/mesh_attributes.py, passes/scene_upload/node_attributes.py)
OP_ATTRIBUTE = 70      # settings: source (ATTRIBUTE_SOURCES), slot within the source
# -- world (opcodes 120-139): the World's Background graph, baked per direction (world_bake.py)
OP_BACKGROUND = 120
OP_TEX_ENVIRONMENT = 121
OP_TEX_SKY = 122

OPCODES = {name: value for name, value in globals().items() if name.startswith("OP_")}

# Operand words.
REGISTER = 0x00000000     # low 16 bits: the register; bits 16-17: the conversion
CONSTANT = 0x80000000     # low 3 bits: the float words that follow (1 to 4)
IMPLICIT = 0x40000000     # low 8 bits: IMPLICIT_* (bits 16-17: the conversion)
NO_REGISTER = 0xFFFFFFFF  # an output nobody reads

# How a linked value changes type on its way into a socket (Blender's implicit conversions).
CONVERT_NONE = 0
CONVERT_SPLAT = 1      # float to vector or colour: (f, f, f), alpha 1
CONVERT_GRAY = 2       # colour to float: Rec.709 luminance (Blender's rgb_to_grayscale)
CONVERT_AVERAGE = 3    # vector to float: the mean of the components

# Values of the shading point an unlinked socket stands for (Blender's hidden defaults).
IMPLICIT_NORMAL = 0     # a Normal socket: the shading normal
IMPLICIT_UV = 1         # Image Texture's Vector: the active UV map
IMPLICIT_GENERATED = 2  # a procedural texture's Vector: Generated coordinates

# The interpreter's register file (vec4 each); a graph that needs more fails to compile.
REGISTERS = 32

# White Noise Texture's ``noise_dimensions`` (include/nodes/tex_white_noise.glsl).
WHITE_NOISE_DIMENSIONS = {"1D": 1, "2D": 2, "3D": 3, "4D": 4}
# Normal Map's ``space`` (node_program.glsl node_normal_map).
NORMAL_MAP_SPACES = {"TANGENT": 0, "OBJECT": 1, "WORLD": 2, "BLENDER_OBJECT": 3, "BLENDER_WORLD": 4}

# The Bump's offset instruction: which differential the shading point moves along.
BUMP_AXIS_NONE, BUMP_AXIS_X, BUMP_AXIS_Y = 0, 1, 2

# -- colour and vector: the int codes of their enums (the headers of gpu_shaders/include/nodes/).
# Color Ramps and curves travel as Cycles' tables of TABLE_SIZE samples, inline in the program
# after the node's operands (one float word per channel and sample).
TABLE_SIZE = 257
RAMP_TABLE_WORDS = TABLE_SIZE * 4        # RGBA per sample
CURVE_TABLE_WORDS = {"CURVE_RGB": TABLE_SIZE * 3, "CURVE_VEC": TABLE_SIZE * 3, "CURVE_FLOAT": TABLE_SIZE}
MATH_OPERATIONS = {name: code for code, name in enumerate((
    "ADD", "SUBTRACT", "MULTIPLY", "DIVIDE", "MULTIPLY_ADD", "POWER", "LOGARITHM", "SQRT", "INVERSE_SQRT",
    "ABSOLUTE", "EXPONENT", "MINIMUM", "MAXIMUM", "LESS_THAN", "GREATER_THAN", "SIGN", "COMPARE", "SMOOTH_MIN",
    "SMOOTH_MAX", "ROUND", "FLOOR", "CEIL", "TRUNC", "FRACT", "MODULO", "FLOORED_MODULO", "WRAP", "SNAP",
    "PINGPONG", "SINE", "COSINE", "TANGENT", "ARCSINE", "ARCCOSINE", "ARCTANGENT", "ARCTAN2", "SINH", "COSH",
    "TANH", "RADIANS", "DEGREES"))}
VECTOR_MATH_OPERATIONS = {name: code for code, name in enumerate((
    "ADD", "SUBTRACT", "MULTIPLY", "DIVIDE", "MULTIPLY_ADD", "CROSS_PRODUCT", "PROJECT", "REFLECT", "REFRACT",
    "FACEFORWARD", "DOT_PRODUCT", "DISTANCE", "LENGTH", "SCALE", "NORMALIZE", "ABSOLUTE", "POWER", "SIGN",
    "MINIMUM", "MAXIMUM", "FLOOR", "CEIL", "FRACTION", "MODULO", "WRAP", "SNAP", "SINE", "COSINE", "TANGENT"))}
MIX_BLENDS = {name: code for code, name in enumerate((
    "MIX", "DARKEN", "MULTIPLY", "BURN", "LIGHTEN", "SCREEN", "DODGE", "ADD", "OVERLAY", "SOFT_LIGHT",
    "LINEAR_LIGHT", "DIFFERENCE", "EXCLUSION", "SUBTRACT", "DIVIDE", "HUE", "SATURATION", "COLOR", "VALUE"))}
MIX_DATA_TYPES = {"FLOAT": 0, "VECTOR": 1, "RGBA": 2, "ROTATION": 3}
MIX_FACTOR_MODES = {"UNIFORM": 0, "NON_UNIFORM": 1}
RAMP_INTERPOLATIONS = {"EASE": 0, "CARDINAL": 1, "LINEAR": 2, "B_SPLINE": 3, "CONSTANT": 4}
MAP_RANGE_DATA_TYPES = {"FLOAT": 0, "FLOAT_VECTOR": 1}
MAP_RANGE_INTERPOLATIONS = {"LINEAR": 0, "STEPPED": 1, "SMOOTHSTEP": 2, "SMOOTHERSTEP": 3}
CLAMP_TYPES = {"MINMAX": 0, "RANGE": 1}
COLOR_MODES = {"RGB": 0, "HSV": 1, "HSL": 2}
MAPPING_TYPES = {"POINT": 0, "TEXTURE": 1, "VECTOR": 2, "NORMAL": 3}
ROTATION_TYPES = {"AXIS_ANGLE": 0, "X_AXIS": 1, "Y_AXIS": 2, "Z_AXIS": 3, "EULER_XYZ": 4}
# The defines that compile each family's cases into the interpreter (GPUScene.defines turns
# one on only when some graph of the scene uses it: a scene pays for what it uses).
FAMILY_COLOUR = "NODE_FAMILY_COLOUR"
FAMILY_VECTOR = "NODE_FAMILY_VECTOR"
# -- attributes: where an Attribute node's value lives. A GEOMETRY slot is a per-corner value of
# the mesh (interpolated at the shading point), an OBJECT or INSTANCER slot one value per
# instance. Compiled only under FAMILY_ATTRIBUTES, which the scene sets when some program
# reads an attribute (a scene without attribute nodes compiles and binds nothing of it).
ATTRIBUTE_SOURCES = {"GEOMETRY": 0, "OBJECT": 1, "INSTANCER": 2}
FAMILY_ATTRIBUTES = "NODE_ATTRIBUTES"
# Environment Texture's ``projection`` (node_program.glsl node_environment_uv).
ENVIRONMENT_PROJECTIONS = {"EQUIRECTANGULAR": 0, "MIRROR_BALL": 1}
# Sky Texture's ``sky_type`` (Blender 5.0): the models include/nodes/tex_sky.glsl evaluates are
# SKY_MODELS_EVALUATED (all four); one outside it would read as black and be named to the artist.
SKY_TYPES = {"SINGLE_SCATTERING": 0, "MULTIPLE_SCATTERING": 1, "PREETHAM": 2, "HOSEK_WILKIE": 3}
SKY_MODELS_EVALUATED = frozenset({"PREETHAM", "SINGLE_SCATTERING", "MULTIPLE_SCATTERING", "HOSEK_WILKIE"})
# -- textures (round 2: procedurals and the Image Texture's mapping) ---------------------------
OP_TEX_NOISE = 80
OP_TEX_WAVE = 81
OP_TEX_VORONOI = 82
OP_TEX_CHECKER = 83
OP_TEX_BRICK = 84
OP_TEX_GRADIENT = 85
OP_TEX_MAGIC = 86
OPCODES.update({name: value for name, value in globals().items() if name.startswith("OP_TEX_")})

# Noise Texture (include/nodes/tex_noise.glsl).
NOISE_DIMENSIONS = {"1D": 1, "2D": 2, "3D": 3, "4D": 4}
NOISE_TYPES = {"FBM": 0, "MULTIFRACTAL": 1, "HYBRID_MULTIFRACTAL": 2, "RIDGED_MULTIFRACTAL": 3, "HETERO_TERRAIN": 4}
# Wave Texture (include/nodes/tex_wave.glsl).
WAVE_TYPES = {"BANDS": 0, "RINGS": 1}
WAVE_BANDS_DIRECTIONS = {"X": 0, "Y": 1, "Z": 2, "DIAGONAL": 3}
WAVE_RINGS_DIRECTIONS = {"X": 0, "Y": 1, "Z": 2, "SPHERICAL": 3}
WAVE_PROFILES = {"SIN": 0, "SAW": 1, "TRI": 2}
# Voronoi Texture (include/nodes/tex_voronoi.glsl).
VORONOI_DIMENSIONS = {"1D": 1, "2D": 2, "3D": 3, "4D": 4}
VORONOI_FEATURES = {"F1": 0, "F2": 1, "SMOOTH_F1": 2, "DISTANCE_TO_EDGE": 3, "N_SPHERE_RADIUS": 4}
VORONOI_METRICS = {"EUCLIDEAN": 0, "MANHATTAN": 1, "CHEBYCHEV": 2, "MINKOWSKI": 3}
# Gradient Texture (include/nodes/tex_gradient.glsl).
GRADIENT_TYPES = {"LINEAR": 0, "QUADRATIC": 1, "EASING": 2, "DIAGONAL": 3, "SPHERICAL": 4,
                  "QUADRATIC_SPHERE": 5, "RADIAL": 6}
# Image Texture's mapping (include/nodes/tex_image_mapping.glsl); Smart renders as Cubic, as
# in Cycles.
IMAGE_PROJECTIONS = {"FLAT": 0, "BOX": 1, "SPHERE": 2, "TUBE": 3}
IMAGE_EXTENSIONS = {"REPEAT": 0, "EXTEND": 1, "CLIP": 2, "MIRROR": 3}
IMAGE_INTERPOLATIONS = {"Linear": 0, "Closest": 1, "Cubic": 2, "Smart": 2}

# The interpreter's texture families: each one's cases and includes are compiled only under
# its define, which the scene sets when one of its programs uses a kind of the family
# (GPUScene.defines), so a graph without procedurals keeps the interpreter small.
TEXTURE_FAMILIES = {
    "TEX_NOISE": "NODE_FAMILY_NOISE", "TEX_WAVE": "NODE_FAMILY_NOISE",
    "TEX_VORONOI": "NODE_FAMILY_VORONOI",
    "TEX_CHECKER": "NODE_FAMILY_PATTERN", "TEX_BRICK": "NODE_FAMILY_PATTERN",
    "TEX_GRADIENT": "NODE_FAMILY_PATTERN", "TEX_MAGIC": "NODE_FAMILY_PATTERN",
    "TEX_IMAGE": "NODE_FAMILY_IMAGE",
}
