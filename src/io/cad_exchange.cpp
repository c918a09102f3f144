// STEP and IGES (cad_exchange.hpp). Built without ALIGN3D_HAS_OCCT (CMake option ALIGN3D_OCCT
// off, and always in the fuzz build) the reader only says so.
//
// With OCCT: the file is checked here before OCCT sees it (size, signature); the read itself is
// OpenCASCADE's, in the module libalign3d_occt.so (src/io/occt/read_cad.cpp), which is loaded on
// the first STEP or IGES file (occt_module.hpp: why) and called in a child process.
#include "cad_exchange.hpp"

#include "io_detail.hpp"

#ifdef ALIGN3D_HAS_OCCT
#include <dlfcn.h>
#include <link.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "align3d/error.hpp"
#include "block_reader.hpp"
#include "isolated_call.hpp"
#include "occt_module.hpp"
#endif

namespace align3d::io::detail {

#ifndef ALIGN3D_HAS_OCCT

bool occt_available() { return false; }

TriangleMesh read_cad_exchange(const std::filesystem::path& path, MeshFormat,
                               const MeshReadSettings&, MeshReadInfo&) {
  fail(path, "STEP and IGES need align3d built with OpenCASCADE (cmake -DALIGN3D_OCCT=ON)");
}

#else

namespace {

namespace fs = std::filesystem;

// OCCT holds the whole entity graph of a file in memory while it transfers it, then the B-rep and
// its tessellation: a 6.4 MB STEP file of 200 parts peaked at 160 MB (Debian 12, OCCT 7.6.3), so a
// file beyond this bound would need tens of GB. Single parts are a few MB; whole assemblies reach a
// few hundred.
constexpr std::uint64_t kMaxCadFileBytes = std::uint64_t{1} << 30;

// The file that holds this code: the align3d executable, the Python extension, or a program that
// links the core.
fs::path this_binary() {
  Dl_info info{};
  link_map* map = nullptr;
  if (dladdr1(reinterpret_cast<void*>(&occt_available), &info, reinterpret_cast<void**>(&map),
              RTLD_DL_LINKMAP) != 0 &&
      map != nullptr && map->l_name != nullptr && map->l_name[0] != '\0') {
    return map->l_name;
  }
  std::error_code error;  // the main program, whose link map has no name
  return fs::read_symlink("/proc/self/exe", error);
}

// $ALIGN3D_OCCT_MODULE, or null when it is unset or empty.
const char* module_override() {
  const char* given = std::getenv("ALIGN3D_OCCT_MODULE");
  return given != nullptr && *given != 0 ? given : nullptr;
}

// Where the module may be, in the order tried: $ALIGN3D_OCCT_MODULE alone when it is set; else
// beside this binary (the build tree's align3d, an installed Python package), in lib/align3d
// beside its bin/ (an installed align3d, wherever the prefix was moved), the install's
// libdir/align3d, and the build tree that made this binary (its tests).
std::vector<fs::path> module_places() {
  if (const char* given = module_override()) return {given};
  std::vector<fs::path> places;
  if (const fs::path self = this_binary(); !self.empty()) {
    places.push_back(self.parent_path() / kOcctModuleName);
    places.push_back(self.parent_path() / ALIGN3D_OCCT_FROM_BIN / kOcctModuleName);
  }
  places.push_back(fs::path(ALIGN3D_OCCT_INSTALLED_DIR) / kOcctModuleName);
  places.push_back(fs::path(ALIGN3D_OCCT_BUILT_DIR) / kOcctModuleName);
  return places;
}

fs::path find_module() {
  std::error_code error;
  for (const fs::path& place : module_places()) {
    if (fs::is_regular_file(place, error)) return place;
  }
  return {};
}

// The module's entry, loaded once, in this process (not in the child: dlopen after fork in a
// threaded program is not safe). Throws IoError naming `path` when the module cannot be loaded.
OcctRead load_module(const fs::path& path) {
  static std::mutex mutex;
  static OcctRead entry = nullptr;
  const std::lock_guard lock(mutex);
  if (entry != nullptr) return entry;
  const fs::path module = find_module();
  if (module.empty()) {
    std::string looked;
    for (const fs::path& place : module_places())
      looked += (looked.empty() ? "" : ", ") + place.string();
    fail(path,
         std::string("STEP and IGES need align3d's OpenCASCADE module ") + kOcctModuleName +
             ", not found (looked for " + looked +
             (module_override() ? ", which ALIGN3D_OCCT_MODULE names)"
                                : "; the environment variable ALIGN3D_OCCT_MODULE may name it)"));
  }
  void* handle = dlopen(module.c_str(), RTLD_NOW | RTLD_LOCAL);
  void* symbol = handle != nullptr ? dlsym(handle, kOcctEntry) : nullptr;
  if (symbol == nullptr) {
    const char* why = dlerror();
    fail(path, "cannot load align3d's OpenCASCADE module " + module.string() + ": " +
                   (why != nullptr ? why : "no entry point"));
  }
  entry = reinterpret_cast<OcctRead>(symbol);
  return entry;
}

// STEP and IGES are text: what OCCT is handed must at least start like one, so that a renamed file
// gets a clear message and OCCT's parsers see only files of their format.
//   STEP (ISO 10303-21, the exchange structure): the keyword "ISO-10303-21;" opens the file, after
//   blanks, comments or a UTF-8 byte-order mark, which some exporters write.
//   IGES (ASCII form): 80-column records whose column 73 names the section, the first being S
//   (start) or, when that section is left out, G (global). OCCT reads neither the compressed nor
//   the binary form.
void check_signature(const std::filesystem::path& path, MeshFormat format) {
  const std::unique_ptr<ByteSource> source = open_file(path, kMaxCadFileBytes);
  std::string head(4096, '\0');
  head.resize(source->read(head.data(), head.size()));
  std::string_view rest = head;
  if (format == MeshFormat::kStep) {
    if (rest.starts_with("\xEF\xBB\xBF")) rest.remove_prefix(3);
    for (;;) {
      while (!rest.empty() && (is_space(rest.front()) || rest.front() == '\n'))
        rest.remove_prefix(1);
      if (!rest.starts_with("/*")) break;
      const std::size_t end = rest.find("*/", 2);
      rest.remove_prefix(end == std::string_view::npos ? rest.size() : end + 2);
    }
    if (!rest.starts_with("ISO-10303-21;")) {
      fail(path, "not a STEP file (it does not start with 'ISO-10303-21;')");
    }
    return;
  }
  while (!rest.empty() && (rest.front() == '\r' || rest.front() == '\n')) rest.remove_prefix(1);
  const std::string_view first = rest.substr(0, rest.find_first_of("\r\n"));
  if (first.size() < 73 || (first[72] != 'S' && first[72] != 'G')) {
    fail(path,
         "not an IGES file in fixed ASCII form (no section letter S or G in column 73 of "
         "its first line)");
  }
}

// The module's mesh bytes (occt_module.hpp) as a TriangleMesh; the chord tolerance into `chord`.
TriangleMesh deserialise(const fs::path& path, const std::string& bytes, double& chord) {
  std::uint64_t counts[2];
  constexpr std::size_t kHead = sizeof chord + sizeof counts;
  constexpr std::size_t kVertex = 3 * sizeof(double), kTriangle = 3 * sizeof(std::uint32_t);
  if (bytes.size() >= kHead) {
    std::memcpy(&chord, bytes.data(), sizeof chord);
    std::memcpy(counts, bytes.data() + sizeof chord, sizeof counts);
  }
  if (bytes.size() < kHead || counts[0] > bytes.size() / kVertex ||
      counts[1] > bytes.size() / kTriangle ||
      bytes.size() != kHead + counts[0] * kVertex + counts[1] * kTriangle) {
    fail(path,
         "align3d's OpenCASCADE module returned a malformed mesh (a module of another build?)");
  }
  TriangleMesh mesh;
  mesh.vertices.resize(counts[0]);
  mesh.triangles.resize(counts[1]);
  const char* data = bytes.data() + kHead;
  for (std::size_t i = 0; i < counts[0]; ++i) {  // Eigen's vector is not trivially copyable
    std::memcpy(mesh.vertices[i].data(), data + i * kVertex, kVertex);
  }
  std::memcpy(mesh.triangles.data(), data + counts[0] * kVertex, counts[1] * kTriangle);
  return mesh;
}

}  // namespace

bool occt_available() { return !find_module().empty(); }

// OpenCASCADE still crashes on some corrupted files (a mutation test killed the process on 1 kind
// of corrupted STEP file and on 6 of 1000 corrupted IGES files, inside its parsers), so the read
// runs in a child process (isolated_call.hpp): a crash there is an IoError naming the file, never
// the caller's end. It costs a fork (copy-on-write) and one copy of the mesh through a pipe.
TriangleMesh read_cad_exchange(const std::filesystem::path& path, MeshFormat format,
                               const MeshReadSettings& settings, MeshReadInfo& info) {
  if (!(settings.chord_tolerance >= 0) || !std::isfinite(settings.chord_tolerance)) {
    throw std::invalid_argument(
        "chord tolerance must be a finite number >= 0 (0: the default), not " +
        std::to_string(settings.chord_tolerance));
  }
  check_signature(path, format);
  const OcctRead read = load_module(path);
  const bool step = format == MeshFormat::kStep;
  const std::string bytes = isolated_call(path, "OpenCASCADE", [&] {
    OcctAnswer answer;
    read(path.c_str(), step, settings.chord_tolerance, answer);
    if (answer.outcome == OcctAnswer::Outcome::kIoError) fail(path, answer.text);
    if (answer.outcome == OcctAnswer::Outcome::kOutOfMemory) fail_out_of_memory(path, answer.text);
    return std::move(answer.text);
  });
  double chord = 0;
  TriangleMesh mesh = deserialise(path, bytes, chord);
  info.format = step ? "step" : "iges";
  info.chord_tolerance = chord;
  return mesh;
}

#endif

}  // namespace align3d::io::detail
