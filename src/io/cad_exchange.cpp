// STEP and IGES through OpenCASCADE (cad_exchange.hpp). Built without ALIGN3D_HAS_OCCT (CMake
// option ALIGN3D_OCCT off, and always in the fuzz build) the reader only says so.
//
// With OCCT: the file is checked before OCCT sees it (size, signature), read and checked for
// broken references, transferred to B-rep shapes, tessellated by BRepMesh to the chord tolerance,
// and every face's triangulation is collected, wound so that solids face outward.
#include "cad_exchange.hpp"

#include "io_detail.hpp"

#ifdef ALIGN3D_HAS_OCCT
#include <BRepBndLib.hxx>
#include <BRepMesh_IncrementalMesh.hxx>
#include <BRep_Tool.hxx>
#include <Bnd_Box.hxx>
#include <IGESControl_Controller.hxx>
#include <IGESControl_Reader.hxx>
#include <IMeshData_Status.hxx>
#include <IMeshTools_Parameters.hxx>
#include <Interface_Check.hxx>
#include <Interface_CheckIterator.hxx>
#include <Interface_InterfaceModel.hxx>
#include <Interface_Static.hxx>
#include <Message.hxx>
#include <Message_Messenger.hxx>
#include <Message_Printer.hxx>
#include <Poly_Triangulation.hxx>
#include <STEPControl_Controller.hxx>
#include <STEPControl_Reader.hxx>
#include <Standard_Failure.hxx>
#include <Standard_OutOfMemory.hxx>
#include <TCollection_HAsciiString.hxx>
#include <TopExp_Explorer.hxx>
#include <TopoDS.hxx>
#include <TopoDS_Face.hxx>
#include <TopoDS_Shape.hxx>
#include <XSControl_WorkSession.hxx>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <mutex>
#include <new>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>

#include "align3d/error.hpp"
#include "block_reader.hpp"
#include "detail/leak_check.hpp"
#include "isolated_call.hpp"
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

// OCCT holds the whole entity graph of a file in memory while it transfers it, then the B-rep and
// its tessellation: a 6.4 MB STEP file of 200 parts peaked at 160 MB (Debian 12, OCCT 7.6.3), so a
// file beyond this bound would need tens of GB. Single parts are a few MB; whole assemblies reach a
// few hundred.
constexpr std::uint64_t kMaxCadFileBytes = std::uint64_t{1} << 30;

// An error text of OCCT made fit for a one-line message: printable ASCII only (its messages quote
// the file, whose bytes may be anything), runs of blanks and the "****" frames of its reports
// dropped, shortened.
std::string occt_text(std::string_view text) {
  constexpr std::size_t kMaxShown = 160;
  std::string out;
  for (const char ch : text) {
    const auto c = static_cast<unsigned char>(ch);
    if (c >= 0x80) continue;
    const char kept = (c > 0x20 && c < 0x7f && c != '*') ? ch : ' ';
    if (kept == ' ' && (out.empty() || out.back() == ' ')) continue;
    out += kept;
  }
  while (!out.empty() && out.back() == ' ') out.pop_back();
  if (out.size() > kMaxShown) out = out.substr(0, kMaxShown) + "...";
  return out;
}

// OCCT reports through Message::DefaultMessenger(), whose printer writes to std::cout, where the
// CLI writes its own output (and library code never prints). For the duration of one read the
// messenger's printers are replaced by one that keeps the first failure's text, for the error
// message, and then restored: a program that wants OCCT's messages keeps them.
class FailureCapture : public Message_Printer {
 public:
  FailureCapture() { SetTraceLevel(Message_Fail); }
  const std::string& first() const { return first_; }

 protected:
  void send(const TCollection_AsciiString& text, const Message_Gravity) const override {
    if (first_.empty()) first_ = occt_text(text.ToCString());
  }

 private:
  mutable std::string first_;  // send() is const in OCCT's interface
};

class SilencedMessenger {
 public:
  SilencedMessenger()
      : messenger_(Message::DefaultMessenger()),
        saved_(messenger_->Printers()),
        capture_(new FailureCapture) {
    messenger_->ChangePrinters().Clear();
    messenger_->AddPrinter(capture_);
  }
  ~SilencedMessenger() { messenger_->ChangePrinters() = saved_; }
  SilencedMessenger(const SilencedMessenger&) = delete;
  SilencedMessenger& operator=(const SilencedMessenger&) = delete;

  // ": <OCCT's first failure>", or nothing when it reported none.
  std::string reason() const {
    return capture_->first().empty() ? std::string() : ": " + capture_->first();
  }

 private:
  Handle(Message_Messenger) messenger_;
  Message_SequenceOfPrinters saved_;
  Handle(FailureCapture) capture_;
};

// OCCT's data exchange keeps process-wide state: the messenger, the Interface_Static parameters
// (the session's length unit), and IGES's C parser (static buffers). One file at a time.
std::mutex& occt_mutex() {
  static std::mutex mutex;
  return mutex;
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

// Sets an Interface_Static string parameter for the lifetime of this object.
class StaticParameter {
 public:
  StaticParameter(const char* name, const char* value)
      : name_(name), saved_(Interface_Static::CVal(name)) {
    Interface_Static::SetCVal(name_, value);
  }
  ~StaticParameter() { Interface_Static::SetCVal(name_, saved_.c_str()); }
  StaticParameter(const StaticParameter&) = delete;
  StaticParameter& operator=(const StaticParameter&) = delete;

 private:
  const char* name_;
  std::string saved_;
};

// OCCT's readers resolve references leniently: an entity that names a missing entity, or one of the
// wrong type, is kept with a null field, which the transfer then dereferences (a segmentation
// fault; 56 of 300 mutated STEP files crashed so before this check). The syntactic checks of the
// entities and the model's global check (a reference to a missing entity inside a list) record
// every such entity, so a file with any is refused before the transfer. Not the semantic checks
// (ModelCheckList(true)): they judge each entity's values too, more than this guard needs.
void check_loaded_model(const std::filesystem::path& path, XSControl_Reader& reader) {
  Interface_CheckIterator checks = reader.WS()->ModelCheckList(/*complete=*/false);
  const Handle(Interface_InterfaceModel) model = reader.WS()->Model();
  if (!model.IsNull() && model->GlobalCheck()->HasFailed()) checks.Add(model->GlobalCheck());
  std::size_t count = 0;
  std::string first;
  for (checks.Start(); checks.More(); checks.Next()) {
    const Handle(Interface_Check)& check = checks.Value();
    if (!check->HasFailed() || count++ > 0) continue;
    if (check->HasEntity() && !model.IsNull()) {
      const Handle(TCollection_HAsciiString) label = model->StringLabel(check->Entity());
      if (!label.IsNull()) first = "entity " + occt_text(label->ToCString()) + ": ";
    }
    first += occt_text(check->CFail(1));
  }
  if (count == 0) return;
  fail(path, "broken file, OpenCASCADE's checks fail (" + first +
                 (count > 1 ? "; " + std::to_string(count - 1) + " more" : std::string()) + ")");
}

// OCCT registers its STEP and IGES controllers (their parameters, editors, protocols) on first use
// and keeps them for the life of the process, in tables LeakSanitizer cannot follow: about 3 kB
// reported as leaked at exit, the same for one file read or many. Registered here, once per
// format, with the leak check looking away in ASan builds, so that it still sees everything else.
void register_controller(MeshFormat format) {
  [[maybe_unused]] const align3d::detail::LeakCheckPause registration_is_not_a_leak;
  if (format == MeshFormat::kStep) {
    STEPControl_Controller::Init();
  } else {
    IGESControl_Controller::Init();
  }
}

// The file's shapes as one (a compound when there are several), in millimetres: OCCT converts from
// the unit the file declares to its session unit, set here to mm (the default, which the calling
// program may have changed).
TopoDS_Shape load_shape(const std::filesystem::path& path, MeshFormat format,
                        const SilencedMessenger& messages) {
  register_controller(format);
  std::unique_ptr<XSControl_Reader> reader;
  if (format == MeshFormat::kStep) {
    reader = std::make_unique<STEPControl_Reader>();
  } else {
    reader = std::make_unique<IGESControl_Reader>();
  }
  const char* kind = format == MeshFormat::kStep ? "STEP" : "IGES";
  const StaticParameter unit("xstep.cascade.unit", "MM");
  switch (reader->ReadFile(path.c_str())) {
    case IFSelect_RetDone:
      break;
    case IFSelect_RetVoid:
      fail(path, std::string("contains no ") + kind + " entities" + messages.reason());
    default:
      fail(path,
           std::string("OpenCASCADE cannot parse this ") + kind + " file" + messages.reason());
  }
  const Handle(Interface_InterfaceModel) model = reader->WS()->Model();
  if (model.IsNull() || model->NbEntities() == 0) {
    fail(path, std::string("contains no ") + kind + " entities");
  }
  check_loaded_model(path, *reader);
  reader->TransferRoots();
  const TopoDS_Shape shape = reader->OneShape();
  if (shape.IsNull()) fail(path, "contains no shape OpenCASCADE can transfer" + messages.reason());
  if (!TopExp_Explorer(shape, TopAbs_FACE).More()) {
    fail(path, "contains no face (no surface: only wires, curves or points)");
  }
  return shape;
}

// The requested tolerance, or kDefaultChordFraction × the diagonal of the shape's bounding box:
// relative to the part, so that the default tessellation is equally fine for a watch part and for
// a car body, and a part has the same triangles whatever unit its file declares.
double chord_tolerance(const std::filesystem::path& path, const TopoDS_Shape& shape,
                       const MeshReadSettings& settings) {
  if (settings.chord_tolerance > 0) return settings.chord_tolerance;
  Bnd_Box box;
  // The exact extent of the surfaces, without the shape's tolerance gaps (useShapeTolerance off):
  // BRepBndLib::Add would widen the box by the B-spline control points and the tolerances.
  BRepBndLib::AddOptimal(shape, box, /*useTriangulation=*/false, /*useShapeTolerance=*/false);
  const double diagonal = box.IsVoid() ? 0.0 : std::sqrt(box.SquareExtent());
  if (!(diagonal > 0) || !std::isfinite(diagonal)) {
    fail(path,
         "the model's bounding box is degenerate (diagonal " + std::to_string(diagonal) + ")");
  }
  return kDefaultChordFraction * diagonal;
}

// Tessellates every face: chord (linear) deflection `chord`, angular deflection kAngularDeflection,
// both absolute. BRepMesh discretises each edge once and every face along it uses those points,
// so the faces of a solid meet at identical vertices (clean_mesh welds them into a closed mesh).
// Sequential: the same file gives the same triangles, and the thread pool is the caller's.
void tessellate(const std::filesystem::path& path, const TopoDS_Shape& shape, double chord) {
  IMeshTools_Parameters parameters;
  parameters.Deflection = chord;
  parameters.Angle = kAngularDeflection;
  parameters.Relative = Standard_False;
  parameters.InParallel = Standard_False;
  BRepMesh_IncrementalMesh mesher(shape, parameters);
  if (!mesher.IsDone() || (mesher.GetStatusFlags() & IMeshData_Failure) != 0) {
    fail(path, "OpenCASCADE could not tessellate the model (chord tolerance " +
                   std::to_string(chord) + ")");
  }
}

// Appends one face's triangulation, placed by its location and wound so that its normal points
// out of the solid: a face used REVERSED in its shell has the opposite normal to its surface's,
// and so does a mirroring location (negative determinant).
void append_face(const std::filesystem::path& path, const TopoDS_Face& face, std::size_t number,
                 TriangleMesh& mesh) {
  TopLoc_Location location;
  const Handle(Poly_Triangulation) triangulation = BRep_Tool::Triangulation(face, location);
  if (triangulation.IsNull() || triangulation->NbTriangles() == 0) {
    fail(path, "face " + std::to_string(number) + " could not be tessellated");
  }
  const gp_Trsf& placement = location.Transformation();
  const bool moved = !location.IsIdentity();
  const bool flip =
      (face.Orientation() == TopAbs_REVERSED) != (placement.VectorialPart().Determinant() < 0);
  const std::size_t first = mesh.vertices.size();
  const int nodes = triangulation->NbNodes();
  if (first + static_cast<std::size_t>(nodes) > std::numeric_limits<std::uint32_t>::max()) {
    fail(path, "more than 2^32 vertices");
  }
  for (int i = 1; i <= nodes; ++i) {
    gp_Pnt p = triangulation->Node(i);
    if (moved) p.Transform(placement);
    mesh.vertices.emplace_back(p.X(), p.Y(), p.Z());
  }
  for (int i = 1; i <= triangulation->NbTriangles(); ++i) {
    int a = 0, b = 0, c = 0;
    triangulation->Triangle(i).Get(a, b, c);
    if (std::min({a, b, c}) < 1 || std::max({a, b, c}) > nodes) {
      fail(path, "face " + std::to_string(number) + ": a triangle index out of range");
    }
    if (flip) std::swap(b, c);
    const auto index = [first](int node) { return static_cast<std::uint32_t>(first + node - 1); };
    mesh.triangles.push_back({index(a), index(b), index(c)});
  }
}

TriangleMesh collect_triangles(const std::filesystem::path& path, const TopoDS_Shape& shape) {
  TriangleMesh mesh;
  std::size_t number = 0;
  for (TopExp_Explorer faces(shape, TopAbs_FACE); faces.More(); faces.Next()) {
    append_face(path, TopoDS::Face(faces.Current()), ++number, mesh);
  }
  return mesh;
}

// OCCT's exceptions derive from Standard_Failure, not std::exception.
[[noreturn]] void fail_occt(const std::filesystem::path& path, const Standard_Failure& failure,
                            const SilencedMessenger& messages) {
  if (failure.IsKind(STANDARD_TYPE(Standard_OutOfMemory))) {
    fail_out_of_memory(path, "the CAD model and its triangles");
  }
  std::string what = occt_text(failure.GetMessageString());
  if (what.empty()) what = failure.DynamicType()->Name();
  fail(path, "OpenCASCADE failed: " + what + messages.reason());
}

}  // namespace

bool occt_available() { return true; }

namespace {

// The read itself (cad_exchange.hpp), in this process; the settings are checked.
TriangleMesh read_in_process(const std::filesystem::path& path, MeshFormat format,
                             const MeshReadSettings& settings, MeshReadInfo& info) {
  const std::lock_guard lock(occt_mutex());
  const SilencedMessenger messages;
  try {
    const TopoDS_Shape shape = load_shape(path, format, messages);
    const double chord = chord_tolerance(path, shape, settings);
    tessellate(path, shape, chord);
    TriangleMesh mesh = collect_triangles(path, shape);
    info.format = format == MeshFormat::kStep ? "step" : "iges";
    info.chord_tolerance = chord;
    return mesh;
  } catch (const Error&) {
    throw;  // this reader's own IoError or DataError
  } catch (const Standard_Failure& failure) {
    fail_occt(path, failure, messages);
  } catch (const std::bad_alloc&) {
    fail_out_of_memory(path, "the CAD model and its triangles");
  } catch (const std::exception& e) {  // the standard library inside OCCT
    fail(path, "OpenCASCADE failed: " + occt_text(e.what()) + messages.reason());
  }
}

// The child's answer (isolated_call.hpp): the chord tolerance, the counts, then the vertices and
// triangles as the machine stores them (the parent is the same program).
std::string serialise(const TriangleMesh& mesh, double chord) {
  const std::uint64_t counts[2] = {mesh.vertices.size(), mesh.triangles.size()};
  std::string bytes(reinterpret_cast<const char*>(&chord), sizeof chord);
  bytes.append(reinterpret_cast<const char*>(counts), sizeof counts);
  bytes.append(reinterpret_cast<const char*>(mesh.vertices.data()),
               mesh.vertices.size() * sizeof(Eigen::Vector3d));
  bytes.append(reinterpret_cast<const char*>(mesh.triangles.data()),
               mesh.triangles.size() * sizeof(mesh.triangles[0]));
  return bytes;
}

TriangleMesh deserialise(const std::string& bytes, double& chord) {
  std::uint64_t counts[2];
  std::memcpy(&chord, bytes.data(), sizeof chord);
  std::memcpy(counts, bytes.data() + sizeof chord, sizeof counts);
  TriangleMesh mesh;
  mesh.vertices.resize(counts[0]);
  mesh.triangles.resize(counts[1]);
  const char* data = bytes.data() + sizeof chord + sizeof counts;
  for (std::size_t i = 0; i < counts[0]; ++i) {  // Eigen's vector is not trivially copyable
    std::memcpy(mesh.vertices[i].data(), data + i * sizeof(Eigen::Vector3d),
                sizeof(Eigen::Vector3d));
  }
  std::memcpy(mesh.triangles.data(), data + counts[0] * sizeof(Eigen::Vector3d),
              counts[1] * sizeof(mesh.triangles[0]));
  return mesh;
}

}  // namespace

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
  const std::string bytes = isolated_call(path, "OpenCASCADE", [&] {
    MeshReadInfo child;
    const TriangleMesh mesh = read_in_process(path, format, settings, child);
    return serialise(mesh, child.chord_tolerance);
  });
  double chord = 0;
  TriangleMesh mesh = deserialise(bytes, chord);
  info.format = format == MeshFormat::kStep ? "step" : "iges";
  info.chord_tolerance = chord;
  return mesh;
}

#endif

}  // namespace align3d::io::detail
