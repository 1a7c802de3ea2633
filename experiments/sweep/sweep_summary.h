// A sweep's summary tables, from its results.csv (experiments/sweep/sweep.h): per method x grid
// point x corruption level, the number of runs and of finished runs; for Dice, mean surface
// distance (mm), HD95 (mm), the template vertices' mean correspondence error (mm) and the run's
// wall time (s) their mean, standard deviation and 95% confidence interval of the mean (Student's
// t with n - 1 degrees of freedom; none for n < 2); and the success rate with its 95% Wilson score
// interval (Wilson 1927, which stays inside [0, 1] and is not empty at 0 or n successes).
// Written as summary.csv (units in the headers), summary.md and summary.tex (booktabs).
#pragma once

#include <filesystem>
#include <string>

namespace dsnake {

struct SummaryTables {
  std::string csv, markdown, latex;
};

// The tables of a results.csv's text; `source` names it in errors (InputError: a missing column,
// a ragged row).
SummaryTables summary_tables(const std::string& results_csv, const std::string& source);

// Reads DIR/results.csv and writes DIR/summary.{csv,md,tex} atomically; InputError when DIR holds
// no results.csv.
void write_summaries(const std::filesystem::path& dir);

// The 95% Wilson score interval of k successes in n trials ({0, 1} for n = 0).
std::pair<double, double> wilson_interval(int k, int n);

}  // namespace dsnake
