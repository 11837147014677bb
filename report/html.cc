#include "report/html.h"

#include <cmath>
#include <cstdio>
#include <sstream>

#include "core/run_record.h"
#include "report/svg_plot.h"

namespace relit::report {

namespace {

constexpr const char* kStyle = R"css(
body { font-family: sans-serif; margin: 0 auto; max-width: 1180px; padding: 0 18px 40px; color: #222; }
h1 { margin-top: 18px; } h2 { border-bottom: 1px solid #ccc; padding-top: 14px; }
nav ul { columns: 2; } nav a { text-decoration: none; }
table { border-collapse: collapse; margin: 8px 0 14px; font-size: 13px; }
th, td { border: 1px solid #ccc; padding: 3px 8px; text-align: left; vertical-align: top; }
th { background: #f0f0f0; } td.num { text-align: right; }
.warning { background: #fff3cd; border: 1px solid #e0b94f; padding: 8px 12px; margin: 8px 0; }
.notrun { background: #eef2f7; border: 1px solid #b8c4d6; padding: 8px 12px; margin: 8px 0; color: #334; }
.error { background: #fde2e1; border: 1px solid #d9534f; padding: 8px 12px; margin: 8px 0; }
figure { display: inline-block; margin: 4px 8px 10px 0; vertical-align: top; }
figcaption { font-size: 12px; color: #555; max-width: 560px; }
img.broken { outline: 3px solid red; min-width: 40px; min-height: 20px; }
pre { background: #f7f7f7; padding: 8px; overflow-x: auto; font-size: 12px; }
)css";

// Runs after every image has loaded or failed. Quiet on success, so any
// console output in a headless check means something went wrong.
constexpr const char* kImageCheck = R"js(
window.addEventListener('load', function () {
  var images = document.images, broken = [];
  for (var i = 0; i < images.length; i++) {
    var image = images[i];
    if (!image.complete || image.naturalWidth === 0) {
      broken.push(image.getAttribute('src'));
      image.className += ' broken';
    }
  }
  document.body.setAttribute('data-image-check',
      (broken.length ? 'broken' : 'ok') + ' images=' + images.length + ' broken=' + broken.length);
  if (broken.length) {
    var note = document.getElementById('image-check');
    note.className = 'error';
    note.textContent = broken.length + ' image(s) of this report failed to load: ' + broken.join(', ');
    console.error('relit report: images failed to load: ' + broken.join(', '));
  }
});
)js";

}  // namespace

std::string Html(const std::string& text) { return XmlEscape(text); }

std::string Fixed(double value, int decimals) {
  if (!std::isfinite(value)) return "–";
  if (std::abs(value) < 0.5 * std::pow(10.0, -decimals)) value = 0;  // no "-0.000"
  char text[64];
  std::snprintf(text, sizeof(text), "%.*f", decimals, value);
  return text;
}

std::string JsonScalarText(const nlohmann::json& value) {
  if (value.is_null()) return "–";
  if (value.is_string()) return value.get<std::string>();
  if (value.is_boolean()) return value.get<bool>() ? "yes" : "no";
  if (value.is_number_integer() || value.is_number_unsigned()) return value.dump();
  if (value.is_number_float()) {
    const double v = value.get<double>();
    char text[64];
    std::snprintf(text, sizeof(text), std::abs(v) >= 1e5 || (v != 0 && std::abs(v) < 1e-3) ? "%.3g" : "%.4g", v);
    return text;
  }
  return value.dump();
}

std::string Table(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows) {
  std::ostringstream out;
  out << "<table>";
  if (!header.empty()) {
    out << "<tr>";
    for (const std::string& h : header) out << "<th>" << Html(h) << "</th>";
    out << "</tr>";
  }
  for (const auto& row : rows) {
    out << "<tr>";
    for (const std::string& cell : row) out << "<td>" << Html(cell) << "</td>";
    out << "</tr>";
  }
  out << "</table>\n";
  return out.str();
}

std::string ScalarTable(const nlohmann::json& object, int max_depth) {
  std::vector<std::vector<std::string>> rows;
  std::function<void(const nlohmann::json&, const std::string&, int)> walk =
      [&](const nlohmann::json& j, const std::string& prefix, int depth) {
        for (auto it = j.begin(); it != j.end(); ++it) {
          const std::string key = prefix.empty() ? it.key() : prefix + "." + it.key();
          const nlohmann::json& v = it.value();
          if (key == "schema") continue;
          if (v.is_object()) {
            if (depth < max_depth) {
              walk(v, key, depth + 1);
            } else {
              rows.push_back({key, "{" + std::to_string(v.size()) + " fields}"});
            }
          } else if (v.is_array()) {
            bool scalars = v.size() <= 8;
            for (const auto& e : v) scalars = scalars && !e.is_structured();
            if (scalars) {
              std::string text;
              for (const auto& e : v) text += (text.empty() ? "" : ", ") + JsonScalarText(e);
              rows.push_back({key, "[" + text + "]"});
            } else {
              rows.push_back({key, "[" + std::to_string(v.size()) + " entries]"});
            }
          } else {
            rows.push_back({key, JsonScalarText(v)});
          }
        }
      };
  if (object.is_object()) walk(object, "", 1);
  return Table({"field", "value"}, rows);
}

std::string Paragraph(const std::string& text) { return "<p>" + Html(text) + "</p>\n"; }

std::string Warning(const std::string& text) { return "<div class=\"warning\">&#9888; " + Html(text) + "</div>\n"; }

std::string NotRunYet(const std::string& missing, const std::string& how_to_run) {
  return "<div class=\"notrun\">Not run yet: " + Html(missing) + " does not exist. " + Html(how_to_run) +
         "</div>\n";
}

Section NotRunSection(Section section, const std::string& missing, const std::string& how_to_run) {
  section.html = NotRunYet(missing, how_to_run);
  return section;
}

std::string ReadError(const std::string& message) {
  return "<div class=\"error\">Could not read this stage's files: " + Html(message) + "</div>\n";
}

std::string Figure(const std::string& src, const std::string& caption, int width_px) {
  std::ostringstream out;
  out << "<figure><img src=\"" << Html(src) << "\" alt=\"" << Html(caption) << "\"";
  if (width_px > 0) out << " width=\"" << width_px << "\"";
  out << "><figcaption>" << Html(caption) << "</figcaption></figure>";
  return out.str();
}

std::string FigureRow(const std::vector<std::string>& figures) {
  std::string out = "<div>";
  for (const std::string& f : figures) out += f;
  return out + "</div>\n";
}

std::string Page(const std::string& title, const std::string& summary_html, const std::vector<Section>& sections) {
  std::ostringstream out;
  out << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>" << Html(title)
      << "</title>\n<style>" << kStyle << "</style>\n</head>\n<body>\n<h1>" << Html(title) << "</h1>\n"
      << "<p>Generated by relit-report " << Html(RelitVersion()) << " at " << Html(CurrentTimeIso8601Utc())
      << ". Everything on this page is in this folder; it needs no network.</p>\n"
      << "<div id=\"image-check\"></div>\n<nav><ul>\n";
  for (const Section& s : sections) out << "<li><a href=\"#" << Html(s.id) << "\">" << Html(s.title) << "</a></li>\n";
  out << "</ul></nav>\n" << summary_html;
  for (const Section& s : sections) {
    out << "<section id=\"" << Html(s.id) << "\">\n<h2>" << Html(s.title) << "</h2>\n" << s.html << "</section>\n";
  }
  out << "<script>" << kImageCheck << "</script>\n</body>\n</html>\n";
  return out.str();
}

}  // namespace relit::report
