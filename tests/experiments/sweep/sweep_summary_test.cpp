// The sweep's summary tables (experiments/sweep/sweep_summary.h) against hand-computed values:
// the Wilson interval against published ones, mean / SD / t-interval of four values, grouping by
// method x grid point x level, missing and stale runs, bad results.csv files, and `dsnake report`.
#include "experiments/sweep/sweep_summary.h"

#include "framework/core/errors.h"
#include "tests/experiments/temp_dir_test.h"

#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <sstream>

namespace dsnake {
namespace {

// Wilson (1927) 95% intervals as tabulated (Newcombe 1998, Table I; Brown, Cai & DasGupta 2001).
TEST(SweepSummary, WilsonIntervalsMatchPublishedValues) {
  const auto check = [](int k, int n, double low, double high) {
    const auto [l, h] = wilson_interval(k, n);
    EXPECT_NEAR(l, low, 5e-5) << k << "/" << n;
    EXPECT_NEAR(h, high, 5e-5) << k << "/" << n;
  };
  check(5, 10, 0.2366, 0.7634);
  check(0, 10, 0.0, 0.2775);
  check(1, 10, 0.0179, 0.4042);
  check(10, 10, 0.7225, 1.0);
  check(81, 263, 0.2553, 0.3662);
  EXPECT_EQ(wilson_interval(0, 0), std::make_pair(0.0, 1.0));
}

std::map<std::string, std::string> row_of(const std::string& csv, int index) {
  std::istringstream in(csv);
  std::string header, line;
  std::getline(in, header);
  for (int i = 0; i <= index; ++i) std::getline(in, line);
  std::map<std::string, std::string> row;
  std::istringstream h(header), l(line);
  std::string key, value;
  while (std::getline(h, key, ',') && std::getline(l, value, ',')) row[key] = value;
  return row;
}

const char* kResults =
    "run_id,method,energies[0].alpha,corruption_level,corruption,seed,status,success,dice,mean_surface_distance,"
    "hausdorff95,correspondence_error_mean,total_s,build,stale\n"
    "a0,snake,0.1,0,clean,0,converged,true,1,0.5,1,,2,v,\n"
    "a1,snake,0.1,0,clean,1,converged,true,2,0.5,1,,2,v,\n"
    "a2,snake,0.1,0,clean,2,converged,false,3,0.5,1,,2,v,\"another build made it (version x, y)\"\n"
    "a3,snake,0.1,0,clean,3,converged,true,4,0.5,1,,2,v,\n"
    "a4,snake,0.1,0,clean,4,missing,,,,,,,,\n"
    "b0,snake,0.3,0,clean,0,converged,true,0.9,0.25,1,0.5,1,v,\n"
    "c0,snake,0.1,1,noise=30,0,diverged,false,,,,,3,v,\n";

// Four Dice values 1, 2, 3, 4 (as numbers, not as Dice): mean 2.5, SD sqrt(5/3) = 1.2909944, the
// 97.5% quantile of Student's t with 3 degrees of freedom 3.1824463, so the interval is
// 2.5 -+ 3.1824463 x 1.2909944 / 2 = [0.4457397, 4.5542603]; success 3 of 4.
TEST(SweepSummary, GroupsAndStatisticsAreTheHandComputedOnes) {
  const SummaryTables t = summary_tables(kResults, "results.csv");
  const auto a = row_of(t.csv, 0), b = row_of(t.csv, 1), c = row_of(t.csv, 2);
  EXPECT_EQ(a.at("method"), "snake");
  EXPECT_EQ(a.at("grid"), "energies[0].alpha=0.1");
  EXPECT_EQ(a.at("runs"), "5");
  EXPECT_EQ(a.at("finished"), "4");
  EXPECT_EQ(a.at("stale"), "1");
  EXPECT_EQ(a.at("successes"), "3");
  EXPECT_EQ(a.at("success_rate"), "0.75");
  EXPECT_EQ(a.at("dice_n"), "4");
  EXPECT_NEAR(std::stod(a.at("dice_mean")), 2.5, 1e-12);
  EXPECT_NEAR(std::stod(a.at("dice_sd")), 1.2909944, 1e-6);
  EXPECT_NEAR(std::stod(a.at("dice_ci95_low")), 0.4457397, 1e-6);
  EXPECT_NEAR(std::stod(a.at("dice_ci95_high")), 4.5542603, 1e-6);
  EXPECT_EQ(a.at("mean_surface_distance_mm_sd"), "0");
  EXPECT_EQ(a.at("correspondence_error_mean_mm_n"), "0");  // no ground-truth correspondence
  EXPECT_EQ(a.at("correspondence_error_mean_mm_mean"), "");
  EXPECT_NEAR(std::stod(a.at("success_ci95_low")), wilson_interval(3, 4).first, 1e-6);
  // One run: a mean, no SD or interval.
  EXPECT_EQ(b.at("grid"), "energies[0].alpha=0.3");
  EXPECT_EQ(b.at("dice_mean"), "0.9");
  EXPECT_EQ(b.at("dice_sd"), "");
  EXPECT_EQ(b.at("dice_ci95_low"), "");
  // A diverged run without metrics counts as finished and failed, with its time.
  EXPECT_EQ(c.at("corruption"), "noise=30");
  EXPECT_EQ(c.at("finished"), "1");
  EXPECT_EQ(c.at("success_rate"), "0");
  EXPECT_EQ(c.at("dice_n"), "0");
  EXPECT_EQ(c.at("time_s_mean"), "3");
  EXPECT_NE(t.markdown.find("| snake | energies[0].alpha=0.1 | clean | 4 of 5 | 3/4 [0.3, 0.95] | 2.5 ± 1.3 [0.446, 4.55] |"),
            std::string::npos)
      << t.markdown;
  EXPECT_NE(t.markdown.find("**1 of these results no longer stand**"), std::string::npos);
  EXPECT_NE(t.latex.find("snake & energies[0].alpha=0.1 & clean & 4 & 3/4 [0.3, 0.95] & 2.5 $\\pm$ 1.3 [0.446, 4.55]"),
            std::string::npos)
      << t.latex;
  EXPECT_NE(t.latex.find("\\begin{tabular}"), std::string::npos);
  EXPECT_NE(t.latex.find("\\bottomrule\n\\end{tabular}\n"), std::string::npos);
}

TEST(SweepSummary, BadResultsFilesNameTheProblem) {
  const auto fails = [](const std::string& text, const std::string& message) {
    try {
      summary_tables(text, "x/results.csv");
      ADD_FAILURE() << "no error for " << text;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
    }
  };
  fails("", "x/results.csv: is empty");
  fails("run_id,method,corruption_level,corruption,status,success\n", "has no column \"dice\"");
  fails(std::string(kResults) + "z,snake,0.1\n", "x/results.csv: row 9: has 3 fields, the header 15");
}

class SweepReportTest : public test_support::TempDirTest {};

TEST_F(SweepReportTest, ReportWritesTheTablesOfAFolderAndRefusesOtherFolders) {
  std::ofstream(dir_ / "results.csv") << kResults;
  const std::string exe = DSNAKE_EXE;
  const std::string out = (dir_ / "stdout.txt").string(), err = (dir_ / "stderr.txt").string();
  EXPECT_EQ(std::system((exe + " report " + dir_.string() + " >" + out + " 2>" + err).c_str()), 0);
  const SummaryTables t = summary_tables(kResults, (dir_ / "results.csv").string());
  EXPECT_EQ(slurp(dir_ / "summary.csv"), t.csv);
  EXPECT_EQ(slurp(dir_ / "summary.tex"), t.latex);
  EXPECT_EQ(slurp(dir_ / "stdout.txt"), t.markdown);
  const int status = std::system((exe + " report " + (dir_ / "none").string() + " >" + out + " 2>" + err).c_str());
  EXPECT_EQ(WEXITSTATUS(status), 2);
  EXPECT_EQ(slurp(dir_ / "stderr.txt"),
            "dsnake: error: " + (dir_ / "none" / "results.csv").string() + ": cannot be read: not a sweep's output folder\n");
}

}  // namespace
}  // namespace dsnake
