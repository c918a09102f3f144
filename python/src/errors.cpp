// C++ exceptions to Python exceptions, in one place. The classes live in align3d/_errors.py:
//   IoError, OutputError            FileError (an OSError; .path is the file)
//   DataError                       DataError (a ValueError; .subject, .problem)
//   UsageError, invalid_argument    SettingsError (a ValueError): a keyword no run can use
//   any other align3d::Error        Error
// Each instance carries .code, the exit code the `align3d` tool gives for the same error
// (error.hpp). std::bad_alloc and the rest keep pybind11's own translation (MemoryError,
// RuntimeError, ...).
#include <stdexcept>
#include <string>

#include "align3d/error.hpp"
#include "binding.hpp"

namespace align3d::python {
namespace {

// Raises align3d._errors.<name>(message) with .code and the given attributes set.
void raise(const char* name, const std::string& message, ExitCode code,
           const py::dict& attributes = {}) {
  const py::object type = py::module_::import("align3d._errors").attr(name);
  py::object error = type(message);
  error.attr("code") = static_cast<int>(code);
  for (const auto& [key, value] : attributes) py::setattr(error, key, value);
  PyErr_SetObject(type.ptr(), error.ptr());
}

}  // namespace

void bind_errors(py::module_&) {
  py::register_exception_translator([](std::exception_ptr thrown) {
    if (!thrown) return;
    try {
      std::rethrow_exception(thrown);
    } catch (const IoError& e) {
      raise("FileError", e.what(), e.code(), py::dict(py::arg("path") = e.path().string()));
    } catch (const OutputError& e) {
      raise("FileError", e.what(), e.code(), py::dict(py::arg("path") = e.path().string()));
    } catch (const DataError& e) {
      raise("DataError", e.what(), e.code(),
            py::dict(py::arg("subject") = e.subject(), py::arg("problem") = e.problem()));
    } catch (const UsageError& e) {
      raise("SettingsError", e.what(), e.code());
    } catch (const Error& e) {
      raise("Error", e.what(), e.code());
    } catch (const std::invalid_argument& e) {
      raise("SettingsError", e.what(), ExitCode::kUsage);
    }
  });
}

}  // namespace align3d::python
