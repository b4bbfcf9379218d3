#include "report/html.h"

#include <cmath>
#include <sstream>

namespace relight::html {

std::string Escape(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&#39;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::string Img(const std::string& src, const std::string& alt, int width_px, const std::string& css_class) {
  std::ostringstream s;
  s << "<img src=\"" << Escape(src) << "\" alt=\"" << Escape(alt) << "\" title=\"" << Escape(alt) << "\"";
  if (width_px > 0) s << " width=\"" << width_px << "\"";
  if (!css_class.empty()) s << " class=\"" << Escape(css_class) << "\"";
  s << ">";
  return s.str();
}

std::string Figure(const std::string& src, const std::string& caption, int width_px, const std::string& css_class) {
  return "<figure>" + Img(src, caption, width_px, css_class) + "<figcaption>" + Escape(caption) +
         "</figcaption></figure>";
}

std::string Table(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows,
                  const std::string& css_class) {
  std::ostringstream s;
  s << "<table" << (css_class.empty() ? "" : " class=\"" + Escape(css_class) + "\"") << "><thead><tr>";
  for (const auto& h : header) s << "<th>" << h << "</th>";
  s << "</tr></thead><tbody>";
  for (const auto& row : rows) {
    s << "<tr>";
    for (const auto& cell : row) s << "<td>" << cell << "</td>";
    s << "</tr>";
  }
  s << "</tbody></table>\n";
  return s.str();
}

std::string Number(double value, int decimals) {
  if (!std::isfinite(value)) return "n/a";
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(decimals);
  s << value;
  return s.str();
}

}  // namespace relight::html
