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
