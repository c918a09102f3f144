#include "align3d/report/html.hpp"

#include <fstream>
#include <sstream>

#include "align3d/error.hpp"

namespace align3d::report {

std::string base64(const std::string& bytes) {
  static const char* kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  for (std::size_t i = 0; i < bytes.size(); i += 3) {
    unsigned v = static_cast<unsigned char>(bytes[i]) << 16;
    if (i + 1 < bytes.size()) v |= static_cast<unsigned char>(bytes[i + 1]) << 8;
    if (i + 2 < bytes.size()) v |= static_cast<unsigned char>(bytes[i + 2]);
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += i + 1 < bytes.size() ? kAlphabet[(v >> 6) & 63] : '=';
    out += i + 2 < bytes.size() ? kAlphabet[v & 63] : '=';
  }
  return out;
}

std::string html_escape(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '&':
        out += "&amp;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::string html_figure(const std::filesystem::path& png, const std::string& caption) {
  std::ifstream in(png, std::ios::binary);
  std::ostringstream bytes;
  bytes << in.rdbuf();
  if (!in) throw OutputError(png, "cannot read the figure back to embed it");
  return html_figure_png(bytes.str(), png.stem().string(), caption);
}

std::string html_figure_png(const std::string& png_bytes, const std::string& alt,
                            const std::string& caption) {
  return "<figure><img alt=\"" + html_escape(alt) + "\" src=\"data:image/png;base64," +
         base64(png_bytes) + "\"><figcaption>" + html_escape(caption) + "</figcaption></figure>\n";
}

std::string html_warnings(const std::vector<Warning>& warnings) {
  if (warnings.empty()) return "<p>No warnings.</p>\n";
  std::string out = "<h2>Warnings</h2>\n<ul>\n";
  for (const Warning& w : warnings) {
    out +=
        "<li class=warn><b>" + html_escape(w.code) + "</b>: " + html_escape(w.message) + "</li>\n";
  }
  return out + "</ul>\n";
}

std::string html_page(const std::string& title, const std::string& body) {
  return "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>" + html_escape(title) +
         "</title><style>body{font-family:sans-serif;max-width:1150px;margin:2em auto;color:#222}"
         "table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:4px 10px}"
         "td.n{text-align:right;font-family:monospace}figure{margin:2em 0}img{max-width:100%}"
         ".warn{color:#a33}</style></head><body>\n" +
         body + "</body></html>\n";
}

}  // namespace align3d::report
