// How the sweep report writes numbers and text: CSV cells, table cells,
// and text made safe for HTML and Markdown. Internal to src/experiments/.
#pragma once
#include <cstddef>
#include <string>

namespace atacom {

// "n = 1: no interval": what a table cell says instead of a statistic it cannot give.
std::string no_stat(size_t n, const char* what);
std::string num(double v);           // a CSV cell: %.12g, "nan"
std::string num_or_empty(double v);  // a statistic not computed (too few seeds): an empty CSV cell
std::string short_num(double v);     // a table cell: %.4g, "-" for NaN
std::string target_num(double v);    // a censored statistic: +inf reads "not reached"
std::string html_escape(const std::string& s);
// Text for Markdown: printable bytes only, HTML's specials as entities and
// Markdown's punctuation backslash-escaped, so a directory name is shown as
// written, never rendered as markup, a link or a heading.
std::string markdown_text(const std::string& s);

}  // namespace atacom
