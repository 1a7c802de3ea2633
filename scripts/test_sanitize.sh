#!/usr/bin/env bash
# The sanitizer stage of CI: builds the `sanitize` preset (clang 14, AddressSanitizer +
# UndefinedBehaviorSanitizer, every error fatal; the libFuzzer targets) and runs, under it, the
# unit and end-to-end tests and a replay of the fuzz corpus (tests/fuzz/corpus). The long
# reproductions (the paper's robustness and figure tests, the real-scan templates and recipes)
# are left to the release suite: under the sanitizers they would take most of CI's 90 minutes;
# so are the Python-side checks of the figure scripts and report.html (report_html: a 3D run and
# a 24-run sweep through the executable, then Chromium), whose C++ paths the other tests cover.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh sanitize
LONG='Reproduction|PoseCapture|Template3d|TemplateCliTest.Colin27|Bunny|RealExperiments|UnitsTest|WorldOrientation|figure_scripts|viewer_files|experiment_schema|report_html'
# HeapSettings: glibc malloc's thresholds, which do not exist under AddressSanitizer's allocator.
NOT_UNDER_ASAN='HeapSettings'
ctest --preset sanitize -j 2 -E "$LONG|$NOT_UNDER_ASAN"
