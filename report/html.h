// HTML building blocks of the report: escaped text, tables, images, notes
// and the page itself (inline CSS, one inline script that checks every
// image; no external resources, so the page works offline).
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace relit::report {

// Escaped text (same rules as XmlEscape).
std::string Html(const std::string& text);

// A table; header and cells are plain text (escaped here).
std::string Table(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows);

// Two-column key/value table of the scalar leaves of `object` (nested keys
// joined with '.', arrays of up to 8 scalars shown inline, longer arrays and
// deeper objects summarised), for files whose fields the report shows as is.
std::string ScalarTable(const nlohmann::json& object, int max_depth = 3);

// "<p>" with escaped text.
std::string Paragraph(const std::string& text);
// A highlighted warning box.
std::string Warning(const std::string& text);
// The note of a section whose stage has not produced its files yet.
std::string NotRunYet(const std::string& missing, const std::string& how_to_run);
// A note for files that exist but could not be read.
std::string ReadError(const std::string& message);

// <img> of a file inside the report folder (`src` relative to index.html),
// with a caption under it.
std::string Figure(const std::string& src, const std::string& caption, int width_px = 0);
// A row of small figures.
std::string FigureRow(const std::vector<std::string>& figures);

// Number formatting for tables.
std::string Fixed(double value, int decimals);
std::string JsonScalarText(const nlohmann::json& value);

struct Section {
  std::string id;     // anchor
  std::string title;
  std::string html;   // body
};

// `section` holding only the NotRunYet note (its stage has not run).
Section NotRunSection(Section section, const std::string& missing, const std::string& how_to_run);

// The whole page: title, table of contents, `summary_html` at the top, the
// sections, and the image check script (marks broken images, writes the
// result into <body data-image-check="...">, logs nothing when all load).
std::string Page(const std::string& title, const std::string& summary_html, const std::vector<Section>& sections);

}  // namespace relit::report
