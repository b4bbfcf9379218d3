// Minimal HTML building blocks for the report: escaping and a few elements.
// Written by hand: the page is a handful of tables and figures, and no Debian
// C++ library offers an HTML template engine worth the dependency.
#pragma once

#include <string>
#include <vector>

namespace relight::html {

// Escapes &, <, >, " and ' for text and attribute values.
std::string Escape(const std::string& text);
// <img src=... alt=... title=...> with a lazy-free, fixed display width (CSS px, 0: natural).
std::string Img(const std::string& src, const std::string& alt, int width_px = 0, const std::string& css_class = "");
// <figure> with an image and a caption.
std::string Figure(const std::string& src, const std::string& caption, int width_px, const std::string& css_class = "");
// A table: header cells and rows of already-escaped cell HTML.
std::string Table(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows,
                  const std::string& css_class = "");
// A number with `digits` significant decimals, or "n/a" for NaN/inf.
std::string Number(double value, int decimals = 2);

}  // namespace relight::html
