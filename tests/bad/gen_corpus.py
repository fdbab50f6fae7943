#!/usr/bin/env python3
"""Writes the bad-input corpus of tests/bad/: NAME.txt (a malformed scene, or a scene
loading a malformed NAME*.obj) and NAME.expect (exit status, then the expected message
INCLUDING its location). The location is not typed by hand: '@@' in a case marks where
the error must be reported and is removed from the file. Run from anywhere:
    python3 tests/bad/gen_corpus.py
Messages start with 'bad/NAME.txt:' so they match however the path is prefixed. The
test checks that the expected message is part of what the program says. Cases added by
hand (a NAME.txt and NAME.expect with no entry here) are left as they are: this script
only writes its own cases' files."""
import os

HERE = os.path.dirname(os.path.abspath(__file__))

CAM = ("OrthographicCamera {\n    center 0 0 10\n    direction 0 0 -1\n    up 0 1 0\n"
       "    size 5\n}\n")
LIGHTS = ("Lights {\n    numLights 1\n    DirectionalLight {\n        direction 0 0 -1\n"
          "        color 1 1 1\n    }\n}\n")
MATS = ("Materials {\n    numMaterials 2\n    PhongMaterial { diffuseColor 1 0 0 }\n"
        "    PhongMaterial { diffuseColor 0 1 0 }\n}\n")
HEAD = CAM + LIGHTS + MATS


def group(body, n=1, mat="    MaterialIndex 0\n"):
    return "Group {\n    numObjects %d\n%s%s}\n" % (n, mat, body)


SPHERE = "    Sphere {\n        center 0 0 0\n        radius 1\n    }\n"


def mesh(name):
    return group("    TriangleMesh {\n        obj_file @@%s\n    }\n" % name)


def mats(body, n):
    return CAM + LIGHTS + "Materials {\n    numMaterials %d\n%s}\n" % (n, body) + group(SPHERE)


PH = "    PhongMaterial { diffuseColor 1 1 1 }\n"

# name: (scene text with @@, message after "error: ", extra files {name: bytes/str},
#        where the message is located: None = the scene, or an OBJ file name)
CASES = {}


def case(name, text, msg, files=None, at_file=None):
    assert name not in CASES, name
    CASES[name] = (text, msg, files or {}, at_file)


# --- misspelled keywords at every level -------------------------------------------
case("unknown_toplevel", "@@Camera {\n}\n" + HEAD, "unknown top-level block 'Camera' (expected one of OrthographicCamera, "
     "PerspectiveCamera, Background, Lights, Materials or Group)")
case("misspelled_center", "OrthographicCamera {\n    @@centre 0 0 10\n", "expected 'center', found 'centre'")
case("misspelled_direction", CAM.replace("    direction", "    @@dirction") + LIGHTS,
     "expected 'direction', found 'dirction'")
case("misspelled_up", CAM.replace("up 0", "@@Up 0"), "expected 'up', found 'Up'")
case("misspelled_size", CAM.replace("size", "@@siz"), "expected 'size', found 'siz'")
case("misspelled_angle",
     "PerspectiveCamera {\n    center 0 0 10\n    direction 0 0 -1\n    up 0 1 0\n    @@fov 30\n}\n",
     "expected 'angle', found 'fov'")
case("misspelled_camera_kind", "@@OrthoCamera {\n    center 0 0 10\n}\n", "unknown top-level block 'OrthoCamera'")
case("background_unknown_field", "Background {\n    @@colour 0 0 0\n}\n", "unknown Background field 'colour'")
case("misspelled_numlights", "Lights {\n    @@numLight 1\n}\n", "expected 'numLights', found 'numLight'")
case("unknown_light", "Lights {\n    numLights 1\n    @@SpotLight {\n    }\n}\n", "unknown light 'SpotLight'")
case("misspelled_light_color",
     "Lights {\n    numLights 1\n    DirectionalLight {\n        direction 0 0 -1\n        @@colour 1 1 1\n    }\n}\n",
     "expected 'color', found 'colour'")
case("misspelled_position",
     "Lights {\n    numLights 1\n    PointLight {\n        @@pos 0 0 0\n        color 1 1 1\n    }\n}\n",
     "expected 'position', found 'pos'")
case("misspelled_attenuation",
     "Lights {\n    numLights 1\n    PointLight {\n        position 0 0 0\n        color 1 1 1\n"
     "        @@attenuate 1 0 0\n    }\n}\n",
     "expected 'attenuation' or '}', found 'attenuate'")
case("misspelled_nummaterials", "Materials {\n    @@nummaterials 1\n}\n",
     "expected 'numMaterials', found 'nummaterials'")
case("unknown_material", mats("    @@Lambert { }\n", 1), "unknown material 'Lambert' (expected one of "
     "PhongMaterial, Material, Checkerboard, Noise, Marble or Wood)")
case("phong_unknown_field", mats("    PhongMaterial {\n        @@shininess 20\n    }\n", 1),
     "unknown PhongMaterial field 'shininess' (expected one of diffuseColor, specularColor, "
     "exponent, reflectiveColor, transparentColor or indexOfRefraction)")
case("checkerboard_capital_index",
     mats(PH + PH + "    Checkerboard {\n        @@MaterialIndex 0\n        materialIndex 1\n    }\n", 3),
     "expected 'materialIndex', found 'MaterialIndex'")
case("marble_field_order",
     mats(PH + PH + "    Marble {\n        materialIndex 0\n        materialIndex 1\n        octaves 3\n"
          "        @@amplitude 2\n        frequency 1\n    }\n", 3),
     "expected 'frequency', found 'amplitude'")
case("material_transform_unknown",
     mats(PH + PH + "    Checkerboard {\n        Transform {\n            @@Scale2 2 2 2\n        }\n"
          "        materialIndex 0\n        materialIndex 1\n    }\n", 3),
     "expected a transformation or '}', found 'Scale2'")
case("misspelled_numobjects", HEAD + "Group {\n    @@numobjects 1\n}\n", "expected 'numObjects', found 'numobjects'")
case("unknown_object", HEAD + group("    @@Sphre {\n        center 0 0 0\n        radius 1\n    }\n"),
     "unknown object 'Sphre'")
case("misspelled_radius", HEAD + group("    Sphere {\n        center 0 0 0\n        @@radus 1\n    }\n"),
     "expected 'radius', found 'radus'")
case("misspelled_offset", HEAD + group("    Plane {\n        normal 0 1 0\n        @@d 1\n    }\n"),
     "expected 'offset', found 'd'")
case("misspelled_vertex2", HEAD + group("    Triangle {\n        vertex0 0 0 0\n        vertex1 1 0 0\n"
                                        "        @@vertex3 0 1 0\n    }\n"),
     "expected 'vertex2', found 'vertex3'")
case("misspelled_obj_file", HEAD + group("    TriangleMesh {\n        @@file cube.obj\n    }\n"),
     "expected 'obj_file', found 'file'")
case("unknown_transformation", HEAD + group("    Transform {\n        @@Shear 1 2 3\n" + SPHERE + "    }\n"),
     "unknown transformation or object 'Shear'")
case("lowercase_keyword", HEAD + "@@group {\n    numObjects 0\n}\n", "unknown top-level block 'group'")

case("misspelled_background_block", "@@BackGround {\n    color 0 0 0\n}\n", "unknown top-level block 'BackGround'")
case("singular_lights_block", "@@Light {\n    numLights 0\n}\n", "unknown top-level block 'Light'")
case("singular_materials_block", "@@Material {\n    numMaterials 0\n}\n", "unknown top-level block 'Material'")
case("misspelled_persp_center", "PerspectiveCamera {\n    @@centre 0 0 10\n", "expected 'center', found 'centre'")
case("misspelled_light_direction",
     "Lights {\n    numLights 1\n    DirectionalLight {\n        @@dir 0 0 -1\n        color 1 1 1\n    }\n}\n",
     "expected 'direction', found 'dir'")
case("misspelled_point_color",
     "Lights {\n    numLights 1\n    PointLight {\n        position 0 0 0\n        @@Color 1 1 1\n    }\n}\n",
     "expected 'color', found 'Color'")
case("misspelled_diffuse", mats("    Material {\n        @@diffuseColour 1 0 0\n    }\n", 1),
     "unknown PhongMaterial field 'diffuseColour'")
case("misspelled_checkerboard", mats(PH + PH + "    @@CheckerBoard {\n        materialIndex 0\n        materialIndex 1\n    }\n", 3),
     "unknown material 'CheckerBoard'")
case("misspelled_octaves",
     mats(PH + PH + "    Wood {\n        materialIndex 0\n        materialIndex 1\n        @@octave 3\n"
          "        frequency 1\n        amplitude 1\n    }\n", 3),
     "expected 'octaves', found 'octave'")
case("misspelled_sphere_center", HEAD + group("    Sphere {\n        @@centre 0 0 0\n        radius 1\n    }\n"),
     "expected 'center', found 'centre'")
case("misspelled_plane_normal", HEAD + group("    Plane {\n        @@norm 0 1 0\n        offset 1\n    }\n"),
     "expected 'normal', found 'norm'")
case("misspelled_vertex0", HEAD + group("    Triangle {\n        @@v0 0 0 0\n        vertex1 1 0 0\n        vertex2 0 1 0\n    }\n"),
     "expected 'vertex0', found 'v0'")
case("misspelled_nested_group", HEAD + group("    @@Grop {\n        numObjects 0\n    }\n"), "unknown object 'Grop'")
case("misspelled_trianglemesh", HEAD + group("    @@TriangleMsh {\n        obj_file cube.obj\n    }\n"),
     "unknown object 'TriangleMsh'")
case("misspelled_transform", HEAD + group("    @@Transfrom {\n" + SPHERE + "    }\n"), "unknown object 'Transfrom'")
case("misspelled_materialindex", HEAD + group(SPHERE, mat="    @@MaterialIdx 0\n"), "unknown object 'MaterialIdx'")

# --- braces -------------------------------------------------------------------------
case("missing_brace", HEAD + "Group {\n    numObjects 1\n    MaterialIndex 0\n" + SPHERE + "@@",
     "unexpected end of file, expected '}'")
case("missing_open_brace", HEAD + group("    Sphere\n        @@center 0 0 0\n        radius 1\n    }\n"),
     "expected '{', found 'center'")
case("extra_close_brace", HEAD + group(SPHERE) + "@@}\n", "unknown top-level block '}'")
case("brace_glued", HEAD + group("    @@Sphere{\n        center 0 0 0\n        radius 1\n    }\n"),
     "unknown object 'Sphere{'")
case("empty_braces_token", "Background @@{}\n", "expected '{', found '{}'")
case("lone_brace", "@@{\n", "unknown top-level block '{'")
case("missing_close_in_sphere", HEAD + group("    Sphere {\n        center 0 0 0\n        radius 1\n    @@MaterialIndex 1\n"),
     "expected '}', found 'MaterialIndex'")

# --- numbers -------------------------------------------------------------------------
case("bad_number_word", HEAD + group("    Sphere {\n        center 0 0 0\n        radius @@one\n    }\n"),
     "expected a number, found 'one'")
case("bad_number_comma", HEAD + group("    Sphere {\n        center @@0,5 0 0\n        radius 1\n    }\n"),
     "expected a number, found '0,5' (numbers are separated by white space, and their "
     "decimal point is '.')")
case("bad_number_two_dots", "Background {\n    color 0.5 @@0.5.5 0\n}\n", "expected a number, found '0.5.5'")
case("nan_value", HEAD + group("    Sphere {\n        center 0 0 0\n        radius @@nan\n    }\n"),
     "number out of range: 'nan'")
case("inf_value", "Background {\n    color 1 @@inf 1\n}\n", "number out of range: 'inf'")
case("overflow_1e999", HEAD + group("    Sphere {\n        center 0 0 @@1e999\n        radius 1\n    }\n"),
     "number out of range: '1e999'")
case("float_overflow_1e39", "Background {\n    ambientLight @@1e39 0 0\n}\n", "number out of range: '1e39'")
case("int_slot_float_numobjects", HEAD + "Group {\n    numObjects @@1.0\n" + SPHERE + "}\n",
     "expected an integer, found '1.0'")
case("int_slot_float_materialindex", HEAD + group(SPHERE, mat="    MaterialIndex @@0.0\n"),
     "expected an integer, found '0.0'")
case("int_slot_float_octaves",
     mats(PH + PH + "    Noise {\n        materialIndex 0\n        materialIndex 1\n        octaves @@2.5\n    }\n", 3),
     "expected an integer, found '2.5'")
case("int_slot_exponent_form", "Lights {\n    numLights @@1e0\n}\n", "expected an integer, found '1e0'")
case("int_overflow", HEAD + "Group {\n    numObjects @@99999999999999999999\n}\n",
     "number out of range: '99999999999999999999'")

# --- counts --------------------------------------------------------------------------
case("too_few_objects", HEAD + "Group {\n    numObjects 2\n    MaterialIndex 0\n" + SPHERE + "@@}\n",
     "numObjects is 2 but the group ends after 1 object")
case("too_many_objects", HEAD + "Group {\n    numObjects 1\n    MaterialIndex 0\n" + SPHERE +
     "    @@Sphere {\n        center 1 0 0\n        radius 1\n    }\n}\n",
     "numObjects is 1 but the group has more objects")
case("too_few_lights", CAM + "Lights {\n    numLights 2\n    DirectionalLight {\n        direction 0 0 -1\n"
     "        color 1 1 1\n    }\n@@}\n", "numLights is 2 but the Lights block ends after 1 light")
case("too_many_lights", CAM + "Lights {\n    numLights 1\n" +
     "    DirectionalLight {\n        direction 0 0 -1\n        color 1 1 1\n    }\n" * 1 +
     "    @@PointLight {\n        position 0 0 0\n        color 1 1 1\n    }\n}\n",
     "numLights is 1 but more lights follow")
case("too_few_materials", mats(PH + PH + "@@", 3).replace("@@}", "@@}", 1),
     "numMaterials is 3 but the Materials block ends after 2 materials")
case("too_many_materials", mats(PH + "    @@" + PH.lstrip(), 1), "numMaterials is 1 but more materials follow")
case("negative_numobjects", HEAD + "Group {\n    numObjects @@-3\n}\n",
     "numObjects must be between 0 and 10000000, found -3")
case("negative_numlights", "Lights {\n    numLights @@-1\n}\n", "numLights must be between 0 and 10000000, found -1")
case("huge_nummaterials", "Materials {\n    numMaterials @@2000000000\n}\n",
     "numMaterials must be between 0 and 10000000, found 2000000000")
case("huge_numobjects", HEAD + "Group {\n    numObjects @@10000001\n}\n",
     "numObjects must be between 0 and 10000000, found 10000001")
case("trailing_materialindex", HEAD + "Group {\n    numObjects 1\n    MaterialIndex 0\n" + SPHERE +
     "    @@MaterialIndex 1\n}\n", "expected '}' after 1 object, found 'MaterialIndex'")

# --- material indices -------------------------------------------------------------------
case("materialindex_out_of_range", HEAD + group(SPHERE, mat="    MaterialIndex @@5\n"),
     "MaterialIndex 5 out of range (2 materials)")
case("materialindex_negative", HEAD + group(SPHERE, mat="    MaterialIndex @@-1\n"),
     "MaterialIndex -1 out of range (2 materials)")
case("materialindex_before_materials", CAM + LIGHTS + group(SPHERE, mat="    MaterialIndex @@0\n") + MATS,
     "MaterialIndex 0 out of range (0 materials: a Materials block must come before the Group)")
case("no_material_selected", HEAD + group("    @@Sphere {\n        center 0 0 0\n        radius 1\n    }\n", mat=""),
     "no material selected for Sphere (MaterialIndex missing)")
case("procedural_index_out_of_range",
     mats(PH + PH + "    Checkerboard {\n        materialIndex 0\n        materialIndex @@7\n    }\n", 3),
     "materialIndex 7 out of range (only earlier materials 0..1 may be used)")
case("procedural_self_reference",
     mats(PH + PH + "    Checkerboard {\n        materialIndex @@2\n        materialIndex 0\n    }\n", 3),
     "materialIndex 2 out of range (only earlier materials 0..1 may be used)")
case("procedural_later_reference",
     mats(PH + "    Wood {\n        materialIndex 0\n        materialIndex @@2\n        octaves 1\n"
          "        frequency 1\n        amplitude 1\n    }\n" + PH, 3),
     "materialIndex 2 out of range (only earlier materials 0..0 may be used)")
case("procedural_first_material",
     mats("    Noise {\n        materialIndex @@0\n        materialIndex 0\n        octaves 1\n    }\n", 1),
     "materialIndex 0 out of range (material 0 cannot refer to another")
case("procedural_negative_index",
     mats(PH + "    Checkerboard {\n        materialIndex @@-1\n        materialIndex 0\n    }\n", 2),
     "materialIndex -1 out of range (only earlier materials 0..0 may be used)")
chain = PH + "".join("    Checkerboard { materialIndex %d materialIndex 0 }\n" % i for i in range(63))
chain += "    @@Checkerboard { materialIndex 63 materialIndex 0 }\n"
case("material_chain_too_deep", mats(chain, 65), "procedural materials nested deeper than 64 levels")
case("octaves_huge",
     mats(PH + PH + "    Marble {\n        materialIndex 0\n        materialIndex 1\n        octaves @@100000\n"
          "        frequency 1\n        amplitude 1\n    }\n", 3),
     "octaves must be between 0 and 32, found 100000")

# --- truncated files ------------------------------------------------------------------
case("truncated_after_keyword", HEAD + "Group {\n    numObjects 1\n    MaterialIndex 0\n    Sphere@@",
     "unexpected end of file, expected '{'")
case("truncated_mid_vec3", HEAD + "Group {\n    numObjects 1\n    MaterialIndex 0\n    Sphere {\n        center 0 0\n@@",
     "unexpected end of file, expected a number")
# What the whole scene lacks is reported where it ends.
case("no_camera", LIGHTS + MATS + group(SPHERE) + "@@",
     "the scene ends without a camera (OrthographicCamera or PerspectiveCamera)")
case("no_group", HEAD + "\n@@", "the scene ends without a Group of objects")
case("empty_file", "@@", "the scene ends without a camera (OrthographicCamera or PerspectiveCamera)")
case("blanks_only", "\n  \n\t\n  @@", "the scene ends without a camera (OrthographicCamera or "
     "PerspectiveCamera)")
case("truncated_in_camera", "OrthographicCamera {\n    center 0 0 10\n    direction@@",
     "unexpected end of file, expected a number")
case("truncated_camera_fields", "PerspectiveCamera {\n    center 0 0 10\n    direction 0 0 -1\n@@",
     "unexpected end of file, expected 'up'")
case("truncated_in_lights", CAM + "Lights {\n    numLights@@", "unexpected end of file, expected an integer")
case("truncated_in_light", CAM + "Lights {\n    numLights 1\n    DirectionalLight {\n        direction 0 0 -1\n@@",
     "unexpected end of file, expected 'color'")
case("truncated_in_materials", CAM + "Materials {\n    numMaterials 1\n    PhongMaterial {\n        diffuseColor 1 1 1\n@@",
     "unexpected end of file, expected '}'")
case("truncated_in_procedural", CAM + "Materials {\n    numMaterials 2\n" + PH + "    Checkerboard {\n        Transform {\n@@",
     "unexpected end of file, expected a transformation or '}'")
case("truncated_in_transform", HEAD + "Group {\n    numObjects 1\n    MaterialIndex 0\n    Transform {\n        Translate 1 0 0\n@@",
     "unexpected end of file, expected an object")
case("truncated_in_mesh", HEAD + "Group {\n    numObjects 1\n    MaterialIndex 0\n    TriangleMesh {\n        obj_file@@",
     "unexpected end of file, expected an OBJ file name")
case("truncated_group_header", HEAD + "Group {@@", "unexpected end of file, expected 'numObjects'")
case("truncated_nested_groups", HEAD + "Group {\n    numObjects 1\n    MaterialIndex 0\n    Group {\n        numObjects 1\n" + SPHERE + "    }\n@@",
     "unexpected end of file, expected '}'")

# --- geometry / camera / light values --------------------------------------------------
case("singular_scale", HEAD + group("    @@Transform {\n        Scale 0 0 0\n" + SPHERE + "    }\n"),
     "singular transformation (the matrix has no inverse)")
case("singular_matrix", HEAD + group("    @@Transform {\n        Matrix {\n            1 0 0 0\n            0 1 0 0\n"
                                     "            0 0 0 0\n            0 0 0 1\n        }\n" + SPHERE + "    }\n"),
     "singular transformation (the matrix has no inverse)")
case("matrix_projective", HEAD + group("    Transform {\n        @@Matrix { 1 0 0 0  0 1 0 0  0 0 1 0  0 0 1 0 }\n" + SPHERE + "    }\n"),
     "Matrix must be affine: its last row must be 0 0 0 1")
case("matrix_too_few_numbers", HEAD + group("    Transform {\n        Matrix { 1 0 0 0  0 1 0 0  0 0 1 0  0 0 0 @@}\n" + SPHERE + "    }\n"),
     "expected a number, found '}'")
case("rotate_without_braces", HEAD + group("    Transform {\n        Rotate @@0 0 1 90\n" + SPHERE + "    }\n"),
     "expected '{', found '0'")
case("rotate_zero_axis", HEAD + group("    Transform {\n        Rotate { @@0 0 0 90 }\n" + SPHERE + "    }\n"),
     "Rotate axis is zero")
# Invertible in exact arithmetic but not in float: not "singular", say what is wrong.
case("transform_scale_1e30", HEAD + group("    @@Transform {\n        Scale 1e30 1e30 1e30\n" + SPHERE + "    }\n"),
     "transformation too extreme to invert in float precision: its scale factors span 1e+30..1e+30")
case("transform_matrix_1e38", HEAD + group("    @@Transform {\n        Matrix {\n            1e38 0 0 0\n            0 1 0 0\n"
     "            0 0 1 0\n            0 0 0 1\n        }\n" + SPHERE + "    }\n"),
     "transformation too extreme to invert in float precision: its scale factors span 1..1e+38")
case("transform_overflow", HEAD + group("    Transform {\n        UniformScale 1e30\n        @@UniformScale 1e30\n" + SPHERE + "    }\n"),
     "transformation overflows (matrix is not finite)")
case("transform_two_objects", HEAD + group("    Transform {\n" + SPHERE + "    @@Sphere {\n        center 1 0 0\n        radius 1\n    }\n    }\n"),
     "a Transform holds exactly one object; expected '}'")
case("transform_no_object", HEAD + group("    Transform {\n        Translate 1 0 0\n    @@}\n"),
     "Transform has no object (expected an object before '}')")
case("sphere_negative_radius", HEAD + group("    Sphere {\n        center 0 0 0\n        @@radius -2\n    }\n"),
     "Sphere radius must not be negative, found -2")
case("plane_zero_normal", HEAD + group("    Plane {\n        @@normal 0 0 0\n        offset 1\n    }\n"),
     "Plane normal is zero")
case("camera_zero_direction", CAM.replace("direction 0 0 -1", "@@direction 0 0 0") + LIGHTS,
     "camera direction is zero")
case("camera_up_parallel", CAM.replace("up 0 1 0", "@@up 0 0 2") + LIGHTS,
     "degenerate camera: up is zero or parallel to direction")
case("camera_zero_size", CAM.replace("size 5", "@@size 0"), "size must be positive, found 0")
case("camera_angle_200", "PerspectiveCamera {\n    center 0 0 10\n    direction 0 0 -1\n    up 0 1 0\n    @@angle 200\n}\n",
     "angle must be more than 0 and less than 180 degrees, found 200")
case("light_zero_direction", CAM + "Lights {\n    numLights 1\n    DirectionalLight {\n        @@direction 0 0 0\n"
     "        color 1 1 1\n    }\n}\n", "light direction is zero")
case("attenuation_all_zero", CAM + "Lights {\n    numLights 1\n    PointLight {\n        position 0 0 0\n"
     "        color 1 1 1\n        @@attenuation 0 0 0\n    }\n}\n", "attenuation 0 0 0 would divide by zero")

case("phong_negative_exponent", mats("    PhongMaterial {\n        @@exponent -2\n    }\n", 1),
     "exponent must not be negative, found -2")
case("phong_zero_ior", mats("    PhongMaterial {\n        transparentColor 1 1 1\n        @@indexOfRefraction 0\n    }\n", 1),
     "indexOfRefraction must be positive, found 0")

# --- nesting, tokens, garbage ---------------------------------------------------------------
deep = HEAD
for i in range(100):
    deep += "    " * min(i, 20) + ("@@" if i == 64 else "") + "Group {\n" + "    " * min(i, 20) + "  numObjects 1\n"
    if i == 0:
        deep += "  MaterialIndex 0\n"
deep += SPHERE + "}\n" * 100
case("deep_nesting", deep, "objects nested deeper than 64 levels")
case("long_token", "@@" + "A" * 5000 + "\n", "token too long (5000 characters, the limit is 4096)")
case("hash_comment", "@@# a comment: the course format has none\n" + HEAD, "unknown top-level block '#' (scene files have no comments)")
case("slash_comment", HEAD + "@@// trailing comment\n", "unknown top-level block '//' (scene files have no comments)")
case("binary_garbage", b"@@\x7fELF\x02\x01\x01\x00\x00garbage \xff\xfe\n",
     "control byte \\x7f in the scene")
# A keyword followed by NUL bytes once made the keyword comparison read past the end of
# the keyword (the reproducers of the reliability issue, byte for byte).
case("scene_tok_is_nul_overread", b"Lights@@\x00\x00x", "control byte \\x00 in the scene")
case("scene_group_nul_overread",
     b"OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }\n"
     b"Lights { numLights 1 DirectionalLight { direction 0 0 -1 color 1 1 1 } }\n"
     b"Materials { numMaterials 2 PhongMaterial { diffuseColor 1 0 0 } PhongMaterial { diffuseColor 0 1 0 } }\n"
     b"Background { color 0 0 0 ambientLight 0.1 0.1 0.1 }\n"
     b"Group@@\x00\x00\x00 { numObjects 0 }\n",
     "control byte \\x00 in the scene")
case("crlf_error", (HEAD + group("    Sphere {\r\n        center 0 0 0\r\n        @@rad 1\r\n    }\r\n")).replace("\n", "\r\n").replace("\r\r\n", "\r\n"),
     "expected 'radius', found 'rad'")
case("utf8_keyword", "@@Gröup {\n", "unknown top-level block 'Gr\\xc3\\xb6up'")

# --- OBJ files -------------------------------------------------------------------------------
TRI3 = "v 0 0 0\nv 1 0 0\nv 0 1 0\n"
case("missing_obj", HEAD + mesh("nothere.obj"), "cannot open OBJ file 'nothere.obj' (tried '")
case("obj_bad_index", HEAD + mesh("obj_bad_index.obj"), "vertex index 9 out of range (3 vertices)",
     {"obj_bad_index.obj": TRI3 + "f 1 2 3\nf 1 2 @@9\n"}, "obj_bad_index.obj")
case("obj_zero_index", HEAD + mesh("obj_zero_index.obj"), "vertex index 0 out of range (indices start at 1)",
     {"obj_zero_index.obj": TRI3 + "f @@0 1 2\n"}, "obj_zero_index.obj")
case("obj_negative_out_of_range", HEAD + mesh("obj_negative_out_of_range.obj"),
     "vertex index -5 out of range (3 vertices)",
     {"obj_negative_out_of_range.obj": TRI3 + "f -1 -2 @@-5\n"}, "obj_negative_out_of_range.obj")
case("obj_bad_number", HEAD + mesh("obj_bad_number.obj"), "malformed number '2x'",
     {"obj_bad_number.obj": "v 0 0 0\nv 1 @@2x 0\nv 0 1 0\nf 1 2 3\n"}, "obj_bad_number.obj")
case("obj_nan", HEAD + mesh("obj_nan.obj"), "number out of range: 'nan'",
     {"obj_nan.obj": "v @@nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"}, "obj_nan.obj")
case("obj_short_vertex", HEAD + mesh("obj_short_vertex.obj"), "vertex needs 3 coordinates, found 2",
     {"obj_short_vertex.obj": "v 0 0 0\nv 1 0@@\nv 0 1 0\nf 1 2 3\n"}, "obj_short_vertex.obj")
case("obj_short_face", HEAD + mesh("obj_short_face.obj"), "face with 2 vertices (at least 3 needed)",
     {"obj_short_face.obj": TRI3 + "@@f 1 2\n"}, "obj_short_face.obj")
case("obj_malformed_slash", HEAD + mesh("obj_malformed_slash.obj"), "malformed face vertex '1/a'",
     {"obj_malformed_slash.obj": TRI3 + "f @@1/a 2 3\n"}, "obj_malformed_slash.obj")
case("obj_crlf_bad_index", HEAD + mesh("obj_crlf_bad_index.obj"), "vertex index 4 out of range (3 vertices)",
     {"obj_crlf_bad_index.obj": (TRI3 + "f 1 2 3\nf 3 2 @@4\n").replace("\n", "\r\n")}, "obj_crlf_bad_index.obj")
case("obj_no_faces", HEAD + mesh("obj_no_faces.obj"), "OBJ file 'obj_no_faces.obj' has no faces",
     {"obj_no_faces.obj": TRI3})
case("obj_binary", HEAD + mesh("obj_binary.bin"), "NUL byte: not a text OBJ file",
     {"obj_binary.bin": b"v 0 0 0\nv 1 0 0\n@@\x00\x01\x02\x03binary"}, "obj_binary.bin")
case("obj_is_directory", HEAD + mesh("obj_dir.obj"), "cannot open OBJ file 'obj_dir.obj' (tried '")


def locate(data):
    """Removes the '@@' marker; returns (data, line, col) of where it was (1-based)."""
    i = data.find(b"@@")
    assert i >= 0 and data.find(b"@@", i + 1) < 0
    before = data[:i]
    line = before.count(b"\n") + 1
    col = len(before) - (before.rfind(b"\n") + 1) + 1
    return data[:i] + data[i + 2:], line, col


def as_bytes(x):
    return x if isinstance(x, bytes) else x.encode("utf-8")


def main():
    d = os.path.join(HERE, "obj_dir.obj")
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, "README"), "w") as fh:
        fh.write("A folder named like an OBJ file: obj_file must refuse it.\n")
    for name, (text, msg, files, at_file) in sorted(CASES.items()):
        data = as_bytes(text)
        where = None
        for fname, content in files.items():
            content = as_bytes(content)
            if at_file == fname:
                content, line, col = locate(content)
                where = "bad/%s:%d:%d" % (fname, line, col)
            with open(os.path.join(HERE, fname), "wb") as fh:
                fh.write(content)
        if b"@@" in data:
            data, line, col = locate(data)
            if where is None:
                where = "bad/%s.txt:%d:%d" % (name, line, col)
        assert where, name
        with open(os.path.join(HERE, name + ".txt"), "wb") as fh:
            fh.write(data)
        with open(os.path.join(HERE, name + ".expect"), "w") as fh:
            fh.write("1\n%s: error: %s\n" % (where, msg))
    print("%d cases" % len(CASES))


if __name__ == "__main__":
    main()
