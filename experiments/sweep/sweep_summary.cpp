#include "experiments/sweep/sweep_summary.h"

#include "experiments/sweep/csv_text.h"

#include "framework/core/atomic_file.h"
#include "framework/core/errors.h"

#include <boost/math/distributions/students_t.hpp>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <vector>

namespace dsnake {

namespace {

using Row = std::vector<std::string>;

// RFC 4180 records: quoted fields may hold commas, doubled quotes and line breaks.
std::vector<Row> parse_csv(const std::string& text) {
  std::vector<Row> rows;
  Row row;
  std::string field;
  bool quoted = false, any = false;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (quoted) {
      if (c == '"' && i + 1 < text.size() && text[i + 1] == '"') field += '"', ++i;
      else if (c == '"') quoted = false;
      else field += c;
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      row.push_back(field), field.clear();
    } else if (c == '\n' || c == '\r') {
      if (c == '\r' && i + 1 < text.size() && text[i + 1] == '\n') ++i;
      row.push_back(field), field.clear();
      rows.push_back(row), row.clear();
      any = false;
      continue;
    } else {
      field += c;
    }
    any = true;
  }
  if (any || !field.empty()) row.push_back(field), rows.push_back(row);
  return rows;
}

std::string number(double v, int digits = 10) {
  if (!std::isfinite(v)) return "";
  char text[64];
  std::snprintf(text, sizeof(text), "%.*g", digits, v);
  return text;
}

// The summarised quantities: results.csv's column, its name with unit in summary.csv, its
// heading in the Markdown and LaTeX tables.
struct Quantity {
  const char* column;
  const char* name;
  const char* heading;
  const char* latex;
};
constexpr Quantity kQuantities[] = {
    {"dice", "dice", "Dice", "Dice"},
    {"mean_surface_distance", "mean_surface_distance_mm", "MSD (mm)", "MSD (mm)"},
    {"hausdorff95", "hausdorff95_mm", "HD95 (mm)", "HD95 (mm)"},
    {"correspondence_error_mean", "correspondence_error_mean_mm", "corr. error (mm)", "corr.\\ error (mm)"},
    {"total_s", "time_s", "time (s)", "time (s)"},
};

struct Stats {
  int n = 0;
  double mean = NAN, sd = NAN, low = NAN, high = NAN;
};

// Mean, sample standard deviation and the t-based 95% confidence interval of the mean.
Stats stats_of(const std::vector<double>& v) {
  Stats s;
  s.n = int(v.size());
  if (s.n == 0) return s;
  double sum = 0;
  for (double x : v) sum += x;
  s.mean = sum / s.n;
  if (s.n < 2) return s;
  double ss = 0;
  for (double x : v) ss += (x - s.mean) * (x - s.mean);
  s.sd = std::sqrt(ss / (s.n - 1));
  const double t = boost::math::quantile(boost::math::students_t(s.n - 1), 0.975);
  s.low = s.mean - t * s.sd / std::sqrt(double(s.n));
  s.high = s.mean + t * s.sd / std::sqrt(double(s.n));
  return s;
}

struct Group {
  std::string method, grid, level, corruption;
  int runs = 0, finished = 0, successes = 0, stale = 0;
  std::vector<std::vector<double>> values = std::vector<std::vector<double>>(std::size(kQuantities));
};

std::string cell(const Stats& s, int digits) {
  if (s.n == 0) return "-";
  std::string t = number(s.mean, digits);
  if (s.n >= 2) t += " ± " + number(s.sd, 2) + " [" + number(s.low, digits) + ", " + number(s.high, digits) + "]";
  return t;
}

std::string latex_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (std::string("&%$#_{}").find(c) != std::string::npos) out += '\\';
    if (c == '~' || c == '^' || c == '\\') {
      out += c == '\\' ? "\\textbackslash{}" : (c == '~' ? "\\textasciitilde{}" : "\\textasciicircum{}");
      continue;
    }
    out += c;
  }
  return out;
}

}  // namespace

std::pair<double, double> wilson_interval(int k, int n) {
  if (n <= 0) return {0.0, 1.0};
  const double z = 1.959963984540054, p = double(k) / n, z2n = z * z / n;
  const double centre = (p + z2n / 2) / (1 + z2n);
  const double half = z / (1 + z2n) * std::sqrt(p * (1 - p) / n + z2n / (4 * n));
  return {std::max(0.0, centre - half), std::min(1.0, centre + half)};
}

SummaryTables summary_tables(const std::string& results_csv, const std::string& source) {
  const std::vector<Row> rows = parse_csv(results_csv);
  if (rows.empty()) throw InputError(source, "", "is empty: no header");
  const Row& header = rows[0];
  std::map<std::string, int> col;
  for (size_t i = 0; i < header.size(); ++i) col[header[i]] = int(i);
  for (const char* needed : {"method", "corruption_level", "corruption", "status", "success"})
    if (!col.count(needed)) throw InputError(source, "", std::string("has no column \"") + needed + "\"");
  for (const Quantity& q : kQuantities)
    if (!col.count(q.column)) throw InputError(source, "", std::string("has no column \"") + q.column + "\"");
  // The grid keys: the columns between method and corruption_level.
  std::vector<int> grid_columns;
  for (int i = col["method"] + 1; i < col["corruption_level"]; ++i) grid_columns.push_back(i);

  std::vector<Group> groups;
  std::map<std::string, size_t> index;
  for (size_t r = 1; r < rows.size(); ++r) {
    const Row& row = rows[r];
    if (row.size() != header.size())
      throw InputError(source, "row " + std::to_string(r + 1), "has " + std::to_string(row.size()) + " fields, the header " +
                                                                   std::to_string(header.size()));
    std::string grid;
    for (int c : grid_columns) grid += (grid.empty() ? "" : ";") + header[c] + "=" + row[c];
    const std::string key = row[col["method"]] + "\x1f" + grid + "\x1f" + row[col["corruption_level"]];
    if (!index.count(key)) {
      index[key] = groups.size();
      groups.push_back({row[col["method"]], grid, row[col["corruption_level"]], row[col["corruption"]]});
    }
    Group& g = groups[index[key]];
    ++g.runs;
    if (row[col["status"]] == "missing") continue;
    ++g.finished;
    g.successes += row[col["success"]] == "true";
    if (col.count("stale") && !row[col["stale"]].empty()) ++g.stale;
    for (size_t q = 0; q < std::size(kQuantities); ++q) {
      const std::string& text = row[col[kQuantities[q].column]];
      char* end = nullptr;
      const double v = text.empty() ? NAN : std::strtod(text.c_str(), &end);
      if (std::isfinite(v)) g.values[q].push_back(v);
    }
  }

  std::ostringstream csv, md, tex;
  csv << "method,grid,corruption_level,corruption,runs,finished,stale,successes,success_rate,success_ci95_low,"
         "success_ci95_high";
  for (const Quantity& q : kQuantities)
    for (const char* part : {"n", "mean", "sd", "ci95_low", "ci95_high"}) csv << "," << q.name << "_" << part;
  csv << "\n";
  md << "| method | grid | corruption | n | success [95% CI] |";
  for (const Quantity& q : kQuantities) md << " " << q.heading << " |";
  md << "\n|---|---|---|---|---|";
  for (size_t q = 0; q < std::size(kQuantities); ++q) md << "---|";
  md << "\n";
  tex << "% dsnake sweep summary (" << latex_escape(source) << "): mean +- SD [95% CI]; success [95% Wilson CI]\n"
      << "\\begin{tabular}{lllr" << std::string(std::size(kQuantities) + 1, 'l') << "}\n\\toprule\n"
      << "method & grid & corruption & $n$ & success";
  for (const Quantity& q : kQuantities) tex << " & " << q.latex;
  tex << " \\\\\n\\midrule\n";
  int stale = 0;
  for (const Group& g : groups) {
    stale += g.stale;
    const auto [low, high] = wilson_interval(g.successes, g.finished);
    const double rate = g.finished > 0 ? double(g.successes) / g.finished : NAN;
    csv << csv_field(g.method) << "," << csv_field(g.grid) << "," << g.level << "," << csv_field(g.corruption) << ","
        << g.runs << "," << g.finished << "," << g.stale << "," << g.successes << "," << number(rate) << ","
        << (g.finished > 0 ? number(low) : "") << "," << (g.finished > 0 ? number(high) : "");
    std::vector<Stats> s;
    for (size_t q = 0; q < std::size(kQuantities); ++q) {
      s.push_back(stats_of(g.values[q]));
      csv << "," << s.back().n << "," << number(s.back().mean) << "," << number(s.back().sd) << "," << number(s.back().low)
          << "," << number(s.back().high);
    }
    csv << "\n";
    const std::string success = g.finished > 0 ? std::to_string(g.successes) + "/" + std::to_string(g.finished) + " [" +
                                                     number(low, 2) + ", " + number(high, 2) + "]"
                                               : "-";
    md << "| " << g.method << " | " << (g.grid.empty() ? "-" : g.grid) << " | " << g.corruption << " | " << g.finished
       << (g.finished < g.runs ? " of " + std::to_string(g.runs) : "") << " | " << success << " |";
    tex << latex_escape(g.method) << " & " << latex_escape(g.grid.empty() ? "-" : g.grid) << " & "
        << latex_escape(g.corruption) << " & " << g.finished << " & " << latex_escape(success);
    for (size_t q = 0; q < s.size(); ++q) {
      md << " " << cell(s[q], 3) << " |";  // three significant digits in the tables for reading
      std::string c = cell(s[q], 3);
      const size_t pm = c.find("±");
      if (pm != std::string::npos) c.replace(pm, std::string("±").size(), "$\\pm$");
      tex << " & " << c;
    }
    md << "\n";
    tex << " \\\\\n";
  }
  tex << "\\bottomrule\n\\end{tabular}\n";
  md << "\nmean ± SD [95% confidence interval of the mean, Student's t]; success: finished runs that met their "
        "thresholds [95% Wilson interval]; n: finished runs.\n";
  if (stale > 0)
    md << "\n**" << stale << " of these results no longer stand** (another build, or changed inputs: results.csv's "
          "column `stale`).\n";
  return {csv.str(), md.str(), tex.str()};
}

void write_summaries(const std::filesystem::path& dir) {
  const std::filesystem::path results = dir / "results.csv";
  std::ifstream in(results, std::ios::binary);
  if (!in) throw InputError(results.string(), "", "cannot be read: not a sweep's output folder");
  std::stringstream text;
  text << in.rdbuf();
  const SummaryTables t = summary_tables(text.str(), results.string());
  write_file_atomically((dir / "summary.csv").string(), t.csv);
  write_file_atomically((dir / "summary.md").string(), t.markdown);
  write_file_atomically((dir / "summary.tex").string(), t.latex);
}

}  // namespace dsnake
