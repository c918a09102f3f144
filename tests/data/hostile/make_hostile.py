#!/usr/bin/python3
"""Writes the hostile-file set of tests/hostile_test.cpp into this folder (run it from anywhere;
the files are committed, this script documents how the binary ones were made). Each file is listed
in manifest.tsv with the command to run it through, the exit code and a phrase of the error."""
import math
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))
os.chdir(HERE)


def write(name, data):
    with open(name, "wb") as f:
        f.write(data.encode() if isinstance(data, str) else data)


def ply_header(fmt, count, props="property float x\nproperty float y\nproperty float z\n", pre=""):
    return f"ply\nformat {fmt} 1.0\n{pre}element vertex {count}\n{props}end_header\n"


def pcd_header(data, points, fields="x y z", size="4 4 4", typ="F F F", count="1 1 1",
               width=None, height="1"):
    width = points if width is None else width
    return (f"VERSION 0.7\nFIELDS {fields}\nSIZE {size}\nTYPE {typ}\nCOUNT {count}\n"
            f"WIDTH {width}\nHEIGHT {height}\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {points}\nDATA {data}\n")


def f32(*v, e="<"):
    return struct.pack(e + "%df" % len(v), *v)


def lzf_literals(raw):
    return b"".join(bytes([len(raw[i:i + 32]) - 1]) + raw[i:i + 32] for i in range(0, len(raw), 32))


nan, inf = math.nan, math.inf

# ---- PLY ----
write("ply_empty.ply", "")
write("ply_truncated_binary_le.ply",
      ply_header("binary_little_endian", 100).encode() + f32(*range(30)))
write("ply_truncated_binary_be.ply",
      ply_header("binary_big_endian", 4).encode() + f32(*range(11), e=">"))
# The first record is whole (a 3-item list), the second stops after x: caught inside the record.
write("ply_truncated_inside_record.ply",
      ply_header("binary_little_endian", 2,
                 "property list uchar int idx\nproperty float x\nproperty float y\n"
                 "property float z\n").encode()
      + bytes([3]) + struct.pack("<3i", 0, 1, 2) + f32(1, 2, 3) + bytes([0]) + f32(4))
write("ply_vertex_count_1e12_binary.ply",
      ply_header("binary_little_endian", 10**12).encode() + f32(1, 2, 3))
write("ply_vertex_count_1e12_ascii.ply", ply_header("ascii", 10**12) + "1 2 3\n")
write("ply_face_count_1e12_before_vertex.ply",
      "ply\nformat binary_little_endian 1.0\nelement face 1000000000000\n"
      "property list uchar int vertex_indices\nelement vertex 1\nproperty float x\n"
      "property float y\nproperty float z\nend_header\n")
write("ply_list_absurd_length.ply",
      ply_header("binary_little_endian", 1,
                 "property float x\nproperty float y\nproperty float z\n"
                 "property list uint float extra\n").encode()
      + f32(1, 2, 3) + struct.pack("<I", 0xFFFFFFFF) + f32(0))
write("ply_list_negative_length.ply",
      ply_header("binary_big_endian", 1,
                 "property list int int idx\nproperty float x\nproperty float y\n"
                 "property float z\n").encode() + struct.pack(">i", -7) + f32(1, 2, 3, e=">"))
write("ply_ascii_list_garbage_length.ply",
      ply_header("ascii", 1,
                 "property float x\nproperty float y\nproperty float z\n"
                 "property list uchar int idx\n") + "1 2 3 2.5 7 8\n")
write("ply_negative_vertex_count.ply", ply_header("ascii", -5) + "1 2 3\n")
write("ply_garbage_vertex_count.ply", ply_header("ascii", "12abc") + "1 2 3\n")
write("ply_missing_end_header.ply",
      "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\n"
      "property float y\nproperty float z\n")
write("ply_non_numeric.ply", ply_header("ascii", 3) + "1 2 3\n4 5 6\n7 eight 9\n")
write("ply_nan_inf_only.ply",
      ply_header("binary_little_endian", 3).encode() + f32(nan, 0, 0, 0, inf, 0, 1, 2, -inf))
write("ply_zero_vertices.ply", ply_header("binary_little_endian", 0))
write("ply_unknown_format.ply", ply_header("binary_middle_endian", 1) + "1 2 3\n")
write("ply_no_z.ply", ply_header("ascii", 1, "property float x\nproperty float y\n") + "1 2\n")
write("ply_x_is_a_list.ply",
      ply_header("ascii", 1, "property list uchar float x\nproperty float y\nproperty float z\n")
      + "1 1 2 3\n")
write("ply_float_list_count.ply",
      ply_header("ascii", 1, "property list float int idx\nproperty float x\nproperty float y\n"
                 "property float z\n") + "0 1 2 3\n")
write("ply_is_a_pcd.ply", pcd_header("ascii", 1) + "1 2 3\n")
write("ply_all_points_identical.ply",
      ply_header("binary_little_endian", 50).encode() + f32(1.5, -2, 3) * 50)

# ---- PCD ----
write("pcd_empty.pcd", "")
write("pcd_truncated_binary.pcd", pcd_header("binary", 10).encode() + f32(*range(20)))
write("pcd_points_1e12_binary.pcd", pcd_header("binary", 10**12).encode() + f32(1, 2, 3))
write("pcd_points_1e12_ascii.pcd", pcd_header("ascii", 10**12) + "1 2 3\n")
write("pcd_negative_width.pcd", pcd_header("ascii", 1, width="-1") + "1 2 3\n")
write("pcd_width_height_overflow.pcd",
      pcd_header("binary", 1, width=str(2**40), height=str(2**40)).replace("POINTS 1\n", "")
      .encode() + f32(1, 2, 3))
write("pcd_points_not_width_height.pcd", pcd_header("ascii", 4, width="2", height="3") + "1 2 3\n")
write("pcd_count_absurd.pcd", pcd_header("ascii", 1, count="1 1 999999999999") + "1 2 3\n")
write("pcd_size_type_mismatch.pcd", pcd_header("ascii", 1, size="4 4 3") + "1 2 3\n")
write("pcd_missing_data_line.pcd", pcd_header("ascii", 1).replace("DATA ascii\n", "") + "1 2 3\n")
write("pcd_non_numeric.pcd", pcd_header("ascii", 2) + "1 2 3\n4 5 six\n")
write("pcd_nan_inf_only.pcd", pcd_header("ascii", 2) + "nan 1 2\n1 inf 2\n")
one = f32(1, 2, 3)
write("pcd_compressed_lying_compressed_size.pcd",
      pcd_header("binary_compressed", 1).encode() + struct.pack("<II", 100000, 12) + lzf_literals(one))
write("pcd_compressed_lying_uncompressed_size.pcd",
      pcd_header("binary_compressed", 1).encode() + struct.pack("<II", 13, 4000) + lzf_literals(one))
write("pcd_compressed_impossible_expansion.pcd",
      pcd_header("binary_compressed", 10**8).encode() + struct.pack("<II", 2, 12 * 10**8 % 2**32)
      + b"\x1f\x00")
# The largest expansion LZF allows (3 bytes -> 264) passes the size checks; the back-reference points
# before the start of the output, which the decompressor must refuse.
write("pcd_compressed_max_expansion_corrupt.pcd",
      pcd_header("binary_compressed", 22).encode() + struct.pack("<II", 3, 264) + b"\xe0\xff\x00")
write("pcd_compressed_corrupt_backref.pcd",
      pcd_header("binary_compressed", 1).encode() + struct.pack("<II", 3, 12) + b"\x20\x05\x00")
write("pcd_compressed_short_size_header.pcd", pcd_header("binary_compressed", 1) + "abc")
write("pcd_collinear.pcd",
      pcd_header("binary", 40).encode() + b"".join(f32(i, 2 * i, -i) for i in range(40)))
write("pcd_viewpoint_six_numbers.pcd",
      pcd_header("ascii", 1).replace("VIEWPOINT 0 0 0 1 0 0 0", "VIEWPOINT 0 0 0 1 0 0") + "1 2 3\n")
# Classic Mac OS line ends ('\r' alone): the header must still be read line by line.
write("pcd_classic_mac_truncated_binary.pcd",
      pcd_header("binary", 3).replace("\n", "\r").encode() + f32(1, 2, 3, 4, 5, 6))

# ---- XYZ / TXT / CSV ----
write("xyz_empty.xyz", "")
write("xyz_non_numeric.xyz", "1 2 3\n4 five 6\n")
write("xyz_two_columns.csv", "x,y,z\n1,2,3\n4,5\n")
write("xyz_nan_inf_only.txt", "nan nan nan\n1 inf 2\n-inf 0 0\n")
write("xyz_comments_only.txt", "# nothing\n\n   \n# here\n")
write("xyz_binary_garbage.xyz", bytes(range(256)) * 2)
write("xyz_is_a_ply.xyz", ply_header("binary_little_endian", 1).encode() + f32(1, 2, 3))
write("xyz_five_points.xyz", "0 0 0\n1 0 0\n0 1 0\n0 0 1\n1 1 1\n")
write("xyz_all_points_identical.csv", "".join("7.25,-1,3\n" for _ in range(30)))
write("xyz_collinear.xyz", "".join(f"{i} {2 * i} {3 - i}\n" for i in range(50)))
write("xyz_classic_mac_non_numeric.xyz", "1 2 3\r4 5 6\r# seven\r7 eight 9\r")
write("cloud.obj", "v 1 2 3\nv 4 5 6\n")
write("cloud_without_extension", "1 2 3\n4 5 6\n")

# ---- matrices ----
write("matrix_empty.txt", "")
write("matrix_three_rows.txt", "1 0 0 0\n0 1 0 0\n0 0 1 0\n")
write("matrix_five_rows.txt", "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n0 0 0 1\n")
write("matrix_row_of_three.txt", "1 0 0 0\n0 1 0\n0 0 1 0\n0 0 0 1\n")
write("matrix_scaled.txt", "2 0 0 0\n0 2 0 0\n0 0 2 0\n0 0 0 1\n")
write("matrix_sheared.txt", "1 0.1 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n")
write("matrix_reflection.txt", "-1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n")
write("matrix_projective_last_row.txt", "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0.5 1\n")
write("matrix_nan.txt", "1 0 0 0\n0 1 0 nan\n0 0 1 0\n0 0 0 1\n")
write("matrix_inf.txt", "1 0 0 inf\n0 1 0 0\n0 0 1 0\n0 0 0 1\n")
write("matrix_garbage.txt", "1 0 0 0\n0 1 0 0\n0 0 x 0\n0 0 0 1\n")
write("matrix_binary.txt", bytes(range(1, 200)))
write("matrix_json.json", "[[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]\n")

# Found in review while fuzzing: no point announced, so the size check passes, and ascii's per-line
# buffer had COUNT 2^24 entries per field (27 GB here) before any line was read.
fields = 200
write("pcd_zero_points_huge_counts.pcd",
      pcd_header("ascii", 0, fields="x y z " + " ".join(f"f{i}" for i in range(fields)),
                 size=" ".join(["4"] * (fields + 3)), typ=" ".join(["F"] * (fields + 3)),
                 count="1 1 1 " + " ".join(["16777216"] * fields)))

# ---- triangle meshes (run as `align3d convert FILE OUT.ply`: "convert-mesh") ----


def stl_binary(facets, count=None, header="binary STL"):
    out = header.encode().ljust(80, b" ") + struct.pack("<I", len(facets) if count is None else count)
    for corners in facets:
        out += f32(0, 0, 1) + f32(*corners) + b"\0\0"
    return out


def stl_ascii(body):
    return "solid s\n" + body + "endsolid s\n"


TRIANGLE = (0, 0, 0, 1, 0, 0, 0, 1, 0)
FACET = "facet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\n"
write("mesh_stl_empty.stl", "")
write("mesh_stl_too_short.stl", "STL?\n")
write("mesh_stl_count_4e9.stl", stl_binary([TRIANGLE], count=0xFFFFFFFF))
write("mesh_stl_truncated_binary.stl", stl_binary([TRIANGLE] * 3, count=10))
# A binary header that starts with "solid", cut short: not to be parsed as text.
write("mesh_stl_solid_header_truncated.stl",
      stl_binary([TRIANGLE] * 2, count=5, header="solid exported by a CAD tool"))
write("mesh_stl_nan_corner.stl", stl_binary([TRIANGLE, (0, 0, 0, nan, 0, 0, 0, 1, 0)]))
write("mesh_stl_inf_corner_ascii.stl", stl_ascii(FACET.replace("vertex 1 0 0", "vertex 1 inf 0")))
write("mesh_stl_ascii_truncated.stl", "solid s\n" + FACET + "facet normal 0 0 1\nouter loop\nvertex 0 0")
write("mesh_stl_ascii_bad_number.stl", stl_ascii(FACET.replace("vertex 0 1 0", "vertex 0 one 0")))
write("mesh_stl_ascii_no_facets.stl", stl_ascii(""))
write("mesh_stl_ascii_out_of_order.stl", stl_ascii("facet normal 0 0 1\nendloop\n"))

OBJ_TRIANGLE = "v 0 0 0\nv 1 0 0\nv 0 1 0\n"
write("mesh_obj_index_out_of_range.obj", OBJ_TRIANGLE + "f 1 2 3\nf 1 2 4\n")
write("mesh_obj_index_zero.obj", OBJ_TRIANGLE + "f 0 1 2\n")
write("mesh_obj_relative_before_first.obj", OBJ_TRIANGLE + "f -1 -2 -4\n")
write("mesh_obj_index_overflow.obj", OBJ_TRIANGLE + "f 1 2 99999999999999999999999\n")
write("mesh_obj_nan_vertex_used.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n")
write("mesh_obj_vertices_only.obj", OBJ_TRIANGLE)
write("mesh_obj_degenerate_only.obj", OBJ_TRIANGLE + "f 1 2\nf 1 1 2\nf 3 2 3 1\n")
write("mesh_obj_binary_garbage.obj", bytes(range(256)) * 2)
write("mesh_obj_bad_corner.obj", OBJ_TRIANGLE + "f 1/1 2/2 three/3\n")

OFF_SQUARE = "0 0 0\n1 0 0\n1 1 0\n0 1 0\n"
write("mesh_off_counts_1e12.off", "OFF\n1000000000000 1000000000000 0\n" + OFF_SQUARE)
write("mesh_off_truncated_faces.off", "OFF\n4 3 0\n" + OFF_SQUARE + "3 0 1 2\n")
write("mesh_off_index_out_of_range.off", "OFF\n4 1 0\n" + OFF_SQUARE + "4 0 1 2 4\n")
write("mesh_off_corner_count_huge.off", "OFF\n4 1 0\n" + OFF_SQUARE + "4294967295 0 1 2\n")
write("mesh_off_binary.off", b"OFF BINARY\n" + struct.pack(">3i", 3, 1, 0) + f32(0, 0, 0, e=">"))
write("mesh_off_is_a_ply.off", ply_header("ascii", 1) + "1 2 3\n")
write("mesh_off_negative_count.off", "OFF\n-3 1 0\n" + OFF_SQUARE)
write("mesh_off_nan_vertex_used.off", "OFF\n3 1 0\n0 0 0\n1 0 nan\n0 1 0\n3 0 1 2\n")


def ply_mesh(fmt, vertices, faces, list_type="list uchar int vertex_indices", face_pre=""):
    return (f"ply\nformat {fmt} 1.0\nelement vertex {vertices}\nproperty float x\nproperty float y\n"
            f"property float z\nelement face {faces}\n{face_pre}property {list_type}\nend_header\n")


PLY_VERTICES = f32(0, 0, 0, 1, 0, 0, 0, 1, 0)
write("mesh_ply_index_out_of_range.ply",
      ply_mesh("binary_little_endian", 3, 1).encode() + PLY_VERTICES + bytes([3])
      + struct.pack("<3i", 0, 1, 3))
write("mesh_ply_negative_index.ply",
      ply_mesh("binary_big_endian", 3, 1).encode() + f32(0, 0, 0, 1, 0, 0, 0, 1, 0, e=">")
      + bytes([3]) + struct.pack(">3i", 0, -1, 2))
write("mesh_ply_face_count_1e12.ply",
      ply_mesh("binary_little_endian", 3, 10**12).encode() + PLY_VERTICES + bytes([3])
      + struct.pack("<3i", 0, 1, 2))
write("mesh_ply_list_count_huge.ply",
      ply_mesh("binary_little_endian", 3, 1, "list uint int vertex_indices").encode() + PLY_VERTICES
      + struct.pack("<I3i", 0xFFFFFFFF, 0, 1, 2))
write("mesh_ply_float_indices.ply",
      ply_mesh("ascii", 3, 1, "list uchar float vertex_indices") + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
write("mesh_ply_truncated_faces.ply",
      ply_mesh("binary_little_endian", 3, 2).encode() + PLY_VERTICES + bytes([3])
      + struct.pack("<3i", 0, 1, 2) + bytes([3]) + struct.pack("<i", 0))
write("mesh_ply_nan_vertex_used.ply",
      ply_mesh("ascii", 3, 1) + "0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n")
write("mesh_ply_degenerate_only.ply",
      ply_mesh("ascii", 3, 2) + "0 0 0\n1 0 0\n0 1 0\n2 0 1\n3 0 1 0\n")
write("mesh_ply_bad_index.ply", ply_mesh("ascii", 3, 1) + "0 0 0\n1 0 0\n0 1 0\n3 0 1 two\n")
write("mesh_unknown_format.3ds", b"MM\x00\x00" + bytes(60))


# ---- STEP / IGES (read through OpenCASCADE; tests/hostile_test.cpp's "convert-mesh") ----
def step_tetrahedron():
    """The entities of a STEP AP214 file of the solid tetrahedron with corners at the origin and at
    10 mm along each axis, as a CAD exporter writes it: product, B-rep, units."""
    corners = [(0, 0, 0), (10, 0, 0), (0, 10, 0), (0, 0, 10)]
    faces = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]  # counter-clockwise seen from outside
    lines = []

    def entity(text):
        lines.append("#%d = %s;" % (len(lines) + 1, text))
        return "#%d" % len(lines)

    def numbers(values):
        return "(" + ",".join("%.6f" % x for x in values) + ")"

    def unit(v):
        n = math.sqrt(sum(x * x for x in v))
        return [x / n for x in v]

    length = entity("( LENGTH_UNIT() NAMED_UNIT(*) SI_UNIT(.MILLI.,.METRE.) )")
    angle = entity("( NAMED_UNIT(*) PLANE_ANGLE_UNIT() SI_UNIT($,.RADIAN.) )")
    solid_angle = entity("( NAMED_UNIT(*) SI_UNIT($,.STERADIAN.) SOLID_ANGLE_UNIT() )")
    accuracy = entity("UNCERTAINTY_MEASURE_WITH_UNIT(LENGTH_MEASURE(1.E-07),%s,"
                      "'distance_accuracy_value','')" % length)
    context = entity("( GEOMETRIC_REPRESENTATION_CONTEXT(3) GLOBAL_UNCERTAINTY_ASSIGNED_CONTEXT"
                     "((%s)) GLOBAL_UNIT_ASSIGNED_CONTEXT((%s,%s,%s)) REPRESENTATION_CONTEXT('','') )"
                     % (accuracy, length, angle, solid_angle))
    points = [entity("CARTESIAN_POINT('',%s)" % numbers(c)) for c in corners]
    vertices = [entity("VERTEX_POINT('',%s)" % p) for p in points]
    edges = {}
    for a in range(4):
        for b in range(a + 1, 4):
            d = [corners[b][k] - corners[a][k] for k in range(3)]
            direction = entity("DIRECTION('',%s)" % numbers(unit(d)))
            vector = entity("VECTOR('',%s,%.6f)" % (direction, math.sqrt(sum(x * x for x in d))))
            line = entity("LINE('',%s,%s)" % (points[a], vector))
            edges[a, b] = entity("EDGE_CURVE('',%s,%s,%s,.T.)" % (vertices[a], vertices[b], line))
    face_ids = []
    for f in faces:
        oriented = []
        for k in range(3):
            a, b = f[k], f[(k + 1) % 3]
            oriented.append(entity("ORIENTED_EDGE('',*,*,%s,%s)"
                                   % (edges[min(a, b), max(a, b)], ".T." if a < b else ".F.")))
        loop = entity("EDGE_LOOP('',(%s))" % ",".join(oriented))
        bound = entity("FACE_OUTER_BOUND('',%s,.T.)" % loop)
        p = [corners[i] for i in f]
        u = [p[1][k] - p[0][k] for k in range(3)]
        v = [p[2][k] - p[0][k] for k in range(3)]
        normal = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]
        placement = entity("AXIS2_PLACEMENT_3D('',%s,%s,%s)"
                           % (points[f[0]], entity("DIRECTION('',%s)" % numbers(unit(normal))),
                              entity("DIRECTION('',%s)" % numbers(unit(u)))))
        plane = entity("PLANE('',%s)" % placement)
        face_ids.append(entity("ADVANCED_FACE('',(%s),%s,.T.)" % (bound, plane)))
    shell = entity("CLOSED_SHELL('',(%s))" % ",".join(face_ids))
    solid = entity("MANIFOLD_SOLID_BREP('',%s)" % shell)
    shape = entity("ADVANCED_BREP_SHAPE_REPRESENTATION('',(%s),%s)" % (solid, context))
    application = entity("APPLICATION_CONTEXT('core data for automotive mechanical design')")
    entity("APPLICATION_PROTOCOL_DEFINITION('international standard','automotive_design',2000,%s)"
           % application)
    product = entity("PRODUCT('tetrahedron','tetrahedron','',(%s))"
                     % entity("PRODUCT_CONTEXT('',%s,'mechanical')" % application))
    formation = entity("PRODUCT_DEFINITION_FORMATION('','',%s)" % product)
    definition = entity("PRODUCT_DEFINITION('design','',%s,%s)" % (
        formation, entity("PRODUCT_DEFINITION_CONTEXT('part definition',%s,'design')" % application)))
    entity("SHAPE_DEFINITION_REPRESENTATION(%s,%s)"
           % (entity("PRODUCT_DEFINITION_SHAPE('','',%s)" % definition), shape))
    return lines


def step_file(lines):
    return ("ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION(('tetrahedron'),'2;1');\n"
            "FILE_NAME('tetrahedron.step','2026-01-01T00:00:00',(''),(''),'','','');\n"
            "FILE_SCHEMA(('AUTOMOTIVE_DESIGN { 1 0 10303 214 1 1 1 1 }'));\nENDSEC;\nDATA;\n"
            + "\n".join(lines) + "\nENDSEC;\nEND-ISO-10303-21;\n")


def first_index(lines, kind):
    return next(i for i, line in enumerate(lines) if "= %s(" % kind in line)


tetrahedron = step_tetrahedron()
# OpenCASCADE keeps a reference to a missing entity, or to one of the wrong type, as a null field
# that its transfer dereferences (a segmentation fault): the reader refuses such files first.
# A direction left out: the vector of the first edge's line names nothing.
dangling = list(tetrahedron)
del dangling[first_index(dangling, "DIRECTION")]
write("step_dangling_reference.step", step_file(dangling))
# The first line's point names a direction instead.
wrong_type = list(tetrahedron)
line = first_index(wrong_type, "LINE")
direction = wrong_type[first_index(wrong_type, "DIRECTION")].split(" ")[0]
fields = wrong_type[line].split(",")  # "#n = LINE(''", point, vector
wrong_type[line] = ",".join([fields[0], direction] + fields[2:])
write("step_wrong_type_reference.step", step_file(wrong_type))
# Cut in the middle of the DATA section.
whole = step_file(tetrahedron)
write("step_truncated.step", whole[:len(whole) // 2])
# Geometry without a surface: a point.
write("step_only_a_point.step", step_file(["#1 = CARTESIAN_POINT('',(1.,2.,3.));"]))
# A STEP file named .igs: IGES is 80-column records, the section letter in column 73.
write("iges_is_a_step.igs", whole)
