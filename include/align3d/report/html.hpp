// Self-contained HTML pages (they open in a browser with no network): figures are embedded as
// base64 PNG data. Used by the chapter's report.html and by every command's --html page.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "align3d/warning.hpp"

namespace align3d::report {

std::string base64(const std::string& bytes);

// <, >, & and " as entities.
std::string html_escape(const std::string& text);

// <figure> with the PNG file embedded and `caption` (escaped) below it. Throws OutputError when
// the file cannot be read.
std::string html_figure(const std::filesystem::path& png, const std::string& caption);
// The same from the PNG's bytes; `alt` (escaped) is the image's alternative text.
std::string html_figure_png(const std::string& png_bytes, const std::string& alt,
                            const std::string& caption);

// "<p>No warnings.</p>", or a "Warnings" heading over a list of each warning's code and message.
std::string html_warnings(const std::vector<Warning>& warnings);

// A whole page: the head with `title` (escaped) and the house style, then `body` (HTML as given).
std::string html_page(const std::string& title, const std::string& body);

}  // namespace align3d::report
