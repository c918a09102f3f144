// The STEP and IGES reader's OpenCASCADE side, built as the module libalign3d_occt.so and loaded
// by the core on the first such file (occt_module.hpp says why). It depends on OCCT and on nothing
// of the core's compiled code: problems are returned in an OcctAnswer, which the core turns into
// its errors, and the mesh as bytes, which it turns into a TriangleMesh.
//
// The file is read and checked for broken references, transferred to B-rep shapes, tessellated by
// BRepMesh to the chord tolerance, and every face's triangulation is collected, wound so that
// solids face outward (cad_exchange.hpp gives the contract).
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
#include <limits>
#include <memory>
#include <mutex>
#include <new>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "align3d/io/mesh_io.hpp"  // kDefaultChordFraction, kAngularDeflection (constants only)
#include "detail/leak_check.hpp"
#include "io/occt_module.hpp"

namespace align3d::io::detail {
namespace {

// A problem with the file (kIoError) or memory (kOutOfMemory), carried to the entry point.
struct Failure {
  OcctAnswer::Outcome outcome;
  std::string text;
};

[[noreturn]] void fail(const std::string& problem) {
  throw Failure{OcctAnswer::Outcome::kIoError, problem};
}

[[noreturn]] void fail_out_of_memory(const std::string& what) {
  throw Failure{OcctAnswer::Outcome::kOutOfMemory, what};
}

// The triangles of every face, as the answer carries them (occt_module.hpp).
struct Triangles {
  std::vector<double> xyz;
  std::vector<std::uint32_t> corners;
  std::size_t vertices() const { return xyz.size() / 3; }
};

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
void check_loaded_model(XSControl_Reader& reader) {
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
  fail("broken file, OpenCASCADE's checks fail (" + first +
       (count > 1 ? "; " + std::to_string(count - 1) + " more" : std::string()) + ")");
}

// OCCT registers its STEP and IGES controllers (their parameters, editors, protocols) on first use
// and keeps them for the life of the process, in tables LeakSanitizer cannot follow: about 3 kB
// reported as leaked at exit, the same for one file read or many. Registered here, once per
// format, with the leak check looking away in ASan builds, so that it still sees everything else.
void register_controller(bool step) {
  [[maybe_unused]] const align3d::detail::LeakCheckPause registration_is_not_a_leak;
  if (step) {
    STEPControl_Controller::Init();
  } else {
    IGESControl_Controller::Init();
  }
}

// The file's shapes as one (a compound when there are several), in millimetres: OCCT converts from
// the unit the file declares to its session unit, set here to mm (the default, which the calling
// program may have changed).
TopoDS_Shape load_shape(const char* path, bool step, const SilencedMessenger& messages) {
  register_controller(step);
  std::unique_ptr<XSControl_Reader> reader;
  if (step) {
    reader = std::make_unique<STEPControl_Reader>();
  } else {
    reader = std::make_unique<IGESControl_Reader>();
  }
  const char* kind = step ? "STEP" : "IGES";
  const StaticParameter unit("xstep.cascade.unit", "MM");
  switch (reader->ReadFile(path)) {
    case IFSelect_RetDone:
      break;
    case IFSelect_RetVoid:
      fail(std::string("contains no ") + kind + " entities" + messages.reason());
    default:
      fail(std::string("OpenCASCADE cannot parse this ") + kind + " file" + messages.reason());
  }
  const Handle(Interface_InterfaceModel) model = reader->WS()->Model();
  if (model.IsNull() || model->NbEntities() == 0) {
    fail(std::string("contains no ") + kind + " entities");
  }
  check_loaded_model(*reader);
  reader->TransferRoots();
  const TopoDS_Shape shape = reader->OneShape();
  if (shape.IsNull()) fail("contains no shape OpenCASCADE can transfer" + messages.reason());
  if (!TopExp_Explorer(shape, TopAbs_FACE).More()) {
    fail("contains no face (no surface: only wires, curves or points)");
  }
  return shape;
}

// The requested tolerance, or kDefaultChordFraction × the diagonal of the shape's bounding box:
// relative to the part, so that the default tessellation is equally fine for a watch part and for
// a car body, and a part has the same triangles whatever unit its file declares.
double chord_tolerance(const TopoDS_Shape& shape, double requested) {
  if (requested > 0) return requested;
  Bnd_Box box;
  // The exact extent of the surfaces, without the shape's tolerance gaps (useShapeTolerance off):
  // BRepBndLib::Add would widen the box by the B-spline control points and the tolerances.
  BRepBndLib::AddOptimal(shape, box, /*useTriangulation=*/false, /*useShapeTolerance=*/false);
  const double diagonal = box.IsVoid() ? 0.0 : std::sqrt(box.SquareExtent());
  if (!(diagonal > 0) || !std::isfinite(diagonal)) {
    fail("the model's bounding box is degenerate (diagonal " + std::to_string(diagonal) + ")");
  }
  return kDefaultChordFraction * diagonal;
}

// Tessellates every face: chord (linear) deflection `chord`, angular deflection kAngularDeflection,
// both absolute. BRepMesh discretises each edge once and every face along it uses those points,
// so the faces of a solid meet at identical vertices (clean_mesh welds them into a closed mesh).
// Sequential: the same file gives the same triangles, and the thread pool is the caller's.
void tessellate(const TopoDS_Shape& shape, double chord) {
  IMeshTools_Parameters parameters;
  parameters.Deflection = chord;
  parameters.Angle = kAngularDeflection;
  parameters.Relative = Standard_False;
  parameters.InParallel = Standard_False;
  BRepMesh_IncrementalMesh mesher(shape, parameters);
  if (!mesher.IsDone() || (mesher.GetStatusFlags() & IMeshData_Failure) != 0) {
    fail("OpenCASCADE could not tessellate the model (chord tolerance " + std::to_string(chord) +
         ")");
  }
}

// Appends one face's triangulation, placed by its location and wound so that its normal points
// out of the solid: a face used REVERSED in its shell has the opposite normal to its surface's,
// and so does a mirroring location (negative determinant).
void append_face(const TopoDS_Face& face, std::size_t number, Triangles& mesh) {
  TopLoc_Location location;
  const Handle(Poly_Triangulation) triangulation = BRep_Tool::Triangulation(face, location);
  if (triangulation.IsNull() || triangulation->NbTriangles() == 0) {
    fail("face " + std::to_string(number) + " could not be tessellated");
  }
  const gp_Trsf& placement = location.Transformation();
  const bool moved = !location.IsIdentity();
  const bool flip =
      (face.Orientation() == TopAbs_REVERSED) != (placement.VectorialPart().Determinant() < 0);
  const std::size_t first = mesh.vertices();
  const int nodes = triangulation->NbNodes();
  if (first + static_cast<std::size_t>(nodes) > std::numeric_limits<std::uint32_t>::max()) {
    fail("more than 2^32 vertices");
  }
  for (int i = 1; i <= nodes; ++i) {
    gp_Pnt p = triangulation->Node(i);
    if (moved) p.Transform(placement);
    mesh.xyz.insert(mesh.xyz.end(), {p.X(), p.Y(), p.Z()});
  }
  for (int i = 1; i <= triangulation->NbTriangles(); ++i) {
    int a = 0, b = 0, c = 0;
    triangulation->Triangle(i).Get(a, b, c);
    if (std::min({a, b, c}) < 1 || std::max({a, b, c}) > nodes) {
      fail("face " + std::to_string(number) + ": a triangle index out of range");
    }
    if (flip) std::swap(b, c);
    const auto index = [first](int node) { return static_cast<std::uint32_t>(first + node - 1); };
    mesh.corners.insert(mesh.corners.end(), {index(a), index(b), index(c)});
  }
}

Triangles collect_triangles(const TopoDS_Shape& shape) {
  Triangles mesh;
  std::size_t number = 0;
  for (TopExp_Explorer faces(shape, TopAbs_FACE); faces.More(); faces.Next()) {
    append_face(TopoDS::Face(faces.Current()), ++number, mesh);
  }
  return mesh;
}

// OCCT's exceptions derive from Standard_Failure, not std::exception.
[[noreturn]] void fail_occt(const Standard_Failure& failure, const SilencedMessenger& messages) {
  if (failure.IsKind(STANDARD_TYPE(Standard_OutOfMemory))) {
    fail_out_of_memory("the CAD model and its triangles");
  }
  std::string what = occt_text(failure.GetMessageString());
  if (what.empty()) what = failure.DynamicType()->Name();
  fail("OpenCASCADE failed: " + what + messages.reason());
}

// The mesh as the answer carries it (occt_module.hpp).
std::string serialise(const Triangles& mesh, double chord) {
  const std::uint64_t counts[2] = {mesh.vertices(), mesh.corners.size() / 3};
  std::string bytes(reinterpret_cast<const char*>(&chord), sizeof chord);
  bytes.append(reinterpret_cast<const char*>(counts), sizeof counts);
  bytes.append(reinterpret_cast<const char*>(mesh.xyz.data()), mesh.xyz.size() * sizeof(double));
  bytes.append(reinterpret_cast<const char*>(mesh.corners.data()),
               mesh.corners.size() * sizeof(std::uint32_t));
  return bytes;
}

}  // namespace

}  // namespace align3d::io::detail

// The module's entry (occt_module.hpp: OcctRead, kOcctEntry).
extern "C" __attribute__((visibility("default"))) void align3d_occt_read(
    const char* path, bool step, double chord, align3d::io::detail::OcctAnswer& answer) {
  using namespace align3d::io::detail;
  using Outcome = OcctAnswer::Outcome;
  const std::lock_guard lock(occt_mutex());
  try {
    const SilencedMessenger messages;
    try {
      const TopoDS_Shape shape = load_shape(path, step, messages);
      const double tolerance = chord_tolerance(shape, chord);
      tessellate(shape, tolerance);
      answer.text = serialise(collect_triangles(shape), tolerance);
      answer.outcome = Outcome::kMesh;
    } catch (const Standard_Failure& failure) {
      fail_occt(failure, messages);
    } catch (const std::bad_alloc&) {
      throw;
    } catch (const std::exception& e) {  // the standard library inside OCCT
      fail("OpenCASCADE failed: " + occt_text(e.what()) + messages.reason());
    }
  } catch (const Failure& failure) {
    answer = {failure.outcome, failure.text};
  } catch (const std::bad_alloc&) {
    answer = {Outcome::kOutOfMemory, "the CAD model and its triangles"};
  } catch (...) {
    answer = {Outcome::kIoError, "OpenCASCADE failed with an unknown exception"};
  }
}
