// Typed errors thrown at align3d's boundaries. Each class maps to one documented exit code of the
// command-line tool (README, "Exit codes"); library code throws, it never prints or exits.
#pragma once

#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>

namespace align3d {

// Exit codes of the `align3d` tool, one per error class.
enum class ExitCode : int {
  kOk = 0,
  kInternal = 1,       // a bug: an unexpected exception
  kUsage = 2,          // bad command line (unknown flag, bad value)
  kInput = 3,          // a file is missing, unreadable, malformed, truncated or of unknown type
  kData = 4,           // the data cannot be used: too few points, degenerate geometry, no plane
  kOutput = 5,         // an output file could not be written
  kNoSolution = 6,     // registration found no usable solution (too few correspondences)
  kWarnings = 7,       // --strict: the result came with warnings (it may be wrong); outputs written
  kBatchFailures = 8,  // batch: some pairs failed; the others' reports were written
  kRejected = 9,       // inspect: the part is out of tolerance (verdict fail); outputs written
  kUnconnected = 10,   // stitch: some scans overlap no other; the others were stitched and the
                       // outputs written
};

class Error : public std::runtime_error {
 public:
  Error(ExitCode code, const std::string& message) : std::runtime_error(message), code_(code) {}
  ExitCode code() const { return code_; }

 private:
  ExitCode code_;
};

// A file cannot be read or parsed. The message is "<path>: <problem>"; for parse errors the
// problem names the line (text formats) or the byte offset (binary formats). path() is the file,
// for a front end that shows it apart (the Python binding's FileError.path).
class IoError : public Error {
 public:
  IoError(const std::filesystem::path& path, const std::string& problem)
      : Error(ExitCode::kInput, path.string() + ": " + problem), path_(path) {}
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

// Writing an output file failed; nothing was left at the destination. The message is
// "<path>: <problem>", path() the destination.
class OutputError : public Error {
 public:
  OutputError(const std::filesystem::path& path, const std::string& problem)
      : Error(ExitCode::kOutput, path.string() + ": " + problem), path_(path) {}
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

// Input data is well-formed but unusable (too few points, all points on a line, no plane).
// The library knows its inputs by their roles ("source", "target"); an error about one of them
// carries the role as its subject and reads "<subject>: <problem>", so a front end that knows the
// file can name it instead (the command-line tool does: "scan.ply (source): 8 points; ...").
class DataError : public Error {
 public:
  explicit DataError(const std::string& message)
      : Error(ExitCode::kData, message), problem_(message) {}
  DataError(const std::string& subject, const std::string& problem)
      : Error(ExitCode::kData, subject + ": " + problem), subject_(subject), problem_(problem) {}
  const std::string& subject() const { return subject_; }  // empty when none was given
  const std::string& problem() const { return problem_; }  // the message without the subject

 private:
  std::string subject_, problem_;
};

class UsageError : public Error {
 public:
  explicit UsageError(const std::string& message) : Error(ExitCode::kUsage, message) {}
};

}  // namespace align3d
