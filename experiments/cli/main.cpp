// The dsnake command line: run or validate an experiment file (or a built-in experiment), or
// compute one external field.
//   dsnake run [CONFIG.json | builtin:NAME] [--out DIR] [--set key.path=value ...]
//              [--field-cache DIR] [--threads N] [--quiet]
//   dsnake validate CONFIG.json [--set ...]
//   dsnake field --image X --type gvf [--param key=value ...] [--field-cache DIR] --out field.mha
//   dsnake convert IN OUT [--compress]   image/volume, mesh or contour to another format
//   dsnake template --mask LABELS --label N [--mirror x|y|z [--image IMAGE | --mirror-plane x=MM]]
//                   [--vertices 400] --out T.off
//                   a template from a label map (experiments/cli/template_command.h)
//   dsnake init --image SCAN --template T [--mask GT] > exp.json
//                   an experiment file for your own scan (experiments/cli/init_command.h)
//   dsnake sweep SWEEP.json [--out DIR] [-j N] [--threads T] [--manifest parallel|slurm]
//                [--aggregate-only] [--quiet]                    (experiments/sweep/sweep.h)
//   dsnake report DIR                a run's or a sweep's report.html (experiments/output/report_step.h)
//   dsnake schema [--markdown]       the experiment file's JSON Schema, or its key tables
// field, convert, template and init take --nifti-transform auto|sform|qform: which NIfTI
// transform places the voxels (framework/io/image_io.h, NiftiTransform).
// Exit codes: 0 done, 2 bad input (one line on stderr naming the file and the JSON path or
// element), 1 anything else (for a sweep: a run failed), 130 a sweep stopped by a signal.
#include "experiments/cli/convert_command.h"
#include "experiments/spec/experiment.h"
#include "experiments/cli/field_command.h"
#include "experiments/cli/heap_settings.h"
#include "experiments/cli/init_command.h"
#include "experiments/output/report_step.h"
#include "experiments/output/runner.h"
#include "experiments/spec/schema.h"
#include "experiments/sweep/sweep.h"
#include "experiments/sweep/sweep_summary.h"
#include "experiments/cli/template_command.h"
#include "framework/core/atomic_file.h"
#include "framework/core/errors.h"
#include "framework/core/json_text.h"

#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <omp.h>
#include <unistd.h>

namespace {

using namespace dsnake;

ExperimentFile load(const std::string& config, const std::vector<std::string>& overrides) {
  if (config.empty()) return builtin_experiment("default", overrides);
  if (config.rfind("builtin:", 0) == 0) return builtin_experiment(config.substr(8), overrides);
  return load_experiment_file(config, overrides);
}

int run(const std::string& config, const std::vector<std::string>& overrides, const std::string& field_cache,
        const RunOptions& options) {
  ExperimentFile file = load(config, overrides);
  // --field-cache DIR is the field's "cache" key, for every run of a sweep alike.
  if (!field_cache.empty() && file.document.contains("field") && file.document["field"].is_object())
    file.document["field"]["cache"] = field_cache;
  nlohmann::ordered_json result;
  OutputOptions output;
  if (file.dimension == 2) {
    auto ex = make_experiment<2>(file);
    output = ex.output;
    result = run_experiment(ex, options);
  } else {
    auto ex = make_experiment<3>(file);
    output = ex.output;
    result = run_experiment(ex, options);
  }
  // The matplotlib figures and report.html (output.report): a report that cannot be written is a
  // warning, not a failed run.
  if (output.figures && output.report) write_report(options.out_dir);
  // A run stopped by the watchdog wrote its outputs (the last positions that passed) but did not
  // register anything: exit code 3, so that scripts and sweeps count it as failed. The line that
  // says where and why is the run's outcome, so --quiet keeps it.
  if (result.value("status", "") == "diverged") {
    std::string where;
    if (const auto d = result.find("divergence"); d != result.end() && d->is_object())
      where = " in phase " + d->value("phase", std::string("?")) + " at iteration " +
              std::to_string(d->value("phase_iteration", 0)) + ": " + d->value("reason", std::string());
    std::fprintf(stderr, "dsnake: the run diverged%s (result.json's \"divergence\"); exit code 3\n", where.c_str());
    return 3;
  }
  return 0;
}

// Checks an experiment file, or a sweep file (one with "base"): every run it expands to is built.
int validate(const std::string& config, const std::vector<std::string>& overrides) {
  if (overrides.empty() && config.rfind("builtin:", 0) != 0) {
    const std::string text = read_input_text(config, "experiment or sweep file");
    const auto doc = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false, /*ignore_comments=*/true);
    if (doc.is_object() && doc.contains("base")) {
      const Sweep s = load_sweep(config, /*validate=*/true);
      std::printf("%s: valid sweep of %zu runs\n", config.c_str(), s.runs.size());
      return 0;
    }
  }
  const ExperimentFile file = load(config, overrides);
  if (file.dimension == 2) make_experiment<2>(file);
  else make_experiment<3>(file);
  std::printf("%s: valid %dD experiment\n", file.path.c_str(), file.dimension);
  return 0;
}

// Expands the sweep file and runs it (children: this executable), or writes its manifest, or
// only aggregates finished runs.
int sweep(const std::string& file, SweepOptions options) {
  const Sweep s = load_sweep(file, /*validate=*/!options.aggregate_only);
  if (options.out_dir.empty())  // `dsnake sweep FILE`: out/<the sweep file's name> (docs/experiment-file.md)
    options.out_dir = (std::filesystem::path("out") / std::filesystem::path(file).stem()).string();
  options.executable = std::filesystem::read_symlink("/proc/self/exe").string();
  const SweepSummary summary = run_sweep(s, options);
  if (summary.interrupted) return 130;
  if (options.manifest.empty()) write_report(options.out_dir);
  return summary.failed > 0 ? 1 : 0;
}

// `dsnake report DIR`: a run folder (result.json) gets its matplotlib figures and report.html; a
// sweep folder (results.csv) DIR/summary.{csv,md,tex} from DIR/results.csv, the Markdown table on
// stdout, and its report.html. Exit 1 when report.html could not be written.
int report(const std::string& folder) {
  const std::filesystem::path dir(folder);
  if (std::filesystem::is_regular_file(dir / "result.json") && !std::filesystem::exists(dir / "results.csv"))
    return write_report(folder) ? 0 : 1;
  write_summaries(folder);
  std::ifstream md(dir / "summary.md");
  std::cout << md.rdbuf();
  return write_report(folder) ? 0 : 1;
}

// Every subcommand's options, filled by CLI11.
struct CommandLine {
  std::string config;
  std::vector<std::string> overrides;
  RunOptions run;
  int threads = 0;
  std::string field_cache;
  std::string validate_config;
  std::vector<std::string> validate_overrides;
  FieldCommandOptions field;
  ConvertCommandOptions convert;
  TemplateCommandOptions templ;
  InitCommandOptions init;
  std::string sweep_file;
  SweepOptions sweep;
  bool schema_markdown = false;
  std::string nifti_transform;  // --nifti-transform of template, convert, field and init ("" = auto)
  std::string report_folder;
  CLI::App *run_cmd = nullptr, *validate_cmd = nullptr, *field_cmd = nullptr, *sweep_cmd = nullptr, *report_cmd = nullptr,
           *schema_cmd = nullptr, *convert_cmd = nullptr, *template_cmd = nullptr,
           *init_cmd = nullptr;
};

// "--set key.path=value", repeatable.
void add_overrides(CLI::App* cmd, std::vector<std::string>& overrides, const char* help) {
  cmd->add_option("--set", overrides, help)
      ->expected(1)
      ->allow_extra_args(false)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
}

// "--nifti-transform auto|sform|qform": checked in dispatch, where the error can name the file.
void add_nifti_transform(CLI::App* cmd, CommandLine& c) {
  cmd->add_option("--nifti-transform", c.nifti_transform,
                  "Which NIfTI transform places the voxels: auto (default: the sform when sform_code > 0, else the "
                  "qform, else pixdim, as nibabel reads it), sform or qform");
}

// The read options of --nifti-transform VALUE for `file`; a bad value names the option and the file.
ImageReadOptions read_options_of(const std::string& value, const std::string& file) {
  ImageReadOptions o;
  if (value.empty()) return o;
  const auto t = enum_from_name<NiftiTransform>(value);
  if (!t) throw InputError(file, "--nifti-transform " + value, "must be " + enum_choices<NiftiTransform>());
  o.nifti_transform = *t;
  return o;
}

void add_run_and_validate(CLI::App& app, CommandLine& c) {
  c.run_cmd = app.add_subcommand("run", "Run an experiment and write its output folder");
  c.run_cmd->add_option("config", c.config,
                        "Experiment file (JSON), or builtin:NAME (default: D-Snake on the paper's Fig. 4 lung slice; classical: a classical snake, circle to square; ellipsoid: 3D); none runs builtin:default");
  c.run_cmd->add_option("--out,-o", c.run.out_dir, "Output folder (default: out/<experiment name>)");
  add_overrides(c.run_cmd, c.overrides, "Override a key of the experiment file: key.path=value (repeatable)");
  c.run_cmd->add_option("--threads,-j", c.threads, "OpenMP threads (default: all cores)")->check(CLI::Range(1, 1024));
  c.run_cmd->add_flag("--quiet,-q", c.run.quiet, "No progress lines on stderr");
  c.run_cmd->add_flag("--force", c.run.force,
                      "Write into a non-empty --out folder that holds no earlier dsnake result (only dsnake's own files are replaced)");
  c.run_cmd->add_option("--field-cache", c.field_cache, "Store and reuse computed fields in this folder");

  c.validate_cmd = app.add_subcommand("validate", "Check an experiment or sweep file without running it");
  c.validate_cmd->add_option("config", c.validate_config, "Experiment file (JSON), sweep file, or builtin:NAME")->required();
  add_overrides(c.validate_cmd, c.validate_overrides, "Override a key: key.path=value (repeatable)");
}

void add_field(CLI::App& app, CommandLine& c) {
  c.field_cmd = app.add_subcommand("field", "Compute one external field from an image and write it (2D: also a PNG)");
  FieldCommandOptions& f = c.field;
  c.field_cmd->add_option("--image", f.image, "Image or volume file")->required();
  c.field_cmd->add_option("--type", f.type, "gradient, gvf, ddgvf, vfc or distance (default gvf)");
  c.field_cmd->add_option("--param", f.params, "A field option key=value (repeatable), e.g. --param mu=0.1")
      ->expected(1)
      ->allow_extra_args(false)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  c.field_cmd->add_option("--field-cache", f.cache, "Field cache folder");
  c.field_cmd->add_option("--out,-o", f.out, "Output vector image (.mha, .mhd, .nii, .nii.gz, .nrrd, .nhdr, .inr, .inr.gz)")->required();
  c.field_cmd->add_option("--png", f.png, "2D figure (default: --out with .png)");
  c.field_cmd->add_flag("--no-png", f.no_png, "No 2D figure");
  add_nifti_transform(c.field_cmd, c);
  c.field_cmd->add_option("--threads,-j", c.threads, "OpenMP threads (default: all cores)")->check(CLI::Range(1, 1024));
}

void add_convert(CLI::App& app, CommandLine& c) {
  c.convert_cmd = app.add_subcommand(
      "convert",
      "Copy an image/volume, mesh or contour to another format (by extension). Images and volumes "
      "(2D, 3D, vector fields): .mha .mhd .nii .nii.gz .nrrd .nhdr .inr .inr.gz, 2D also .png .tif "
      ".tiff .jpg .jpeg .bmp, and as input a NIfTI pair .hdr/.img (either names it; NIfTI-1 or -2, "
      "also gzipped); spacing, origin and direction are kept (and the voxel order, where the output "
      "format stores a direction), the voxel values go through as "
      "float32 (8-bit grey for the 2D raster formats). Meshes: .off .obj .ply .stl .vtk; contours: "
      ".txt .json .vtk; vertex order kept. Nothing is written on an error (exit code 2)");
  c.convert_cmd->add_option("in", c.convert.in, "Input file")->required();
  c.convert_cmd->add_option("out", c.convert.out, "Output file")->required();
  c.convert_cmd->add_flag("--compress", c.convert.compress, "zlib-compressed MetaImage data, gzip-encoded NRRD");
  add_nifti_transform(c.convert_cmd, c);
}

void add_init(CLI::App& app, CommandLine& c) {
  c.init_cmd = app.add_subcommand("init",
                                  "Print a complete experiment file for your own scan with the recommended settings "
                                  "(dsnake init --image SCAN --template T [--mask GT] > exp.json)");
  InitCommandOptions& i = c.init;
  c.init_cmd->add_option("--image", i.image, "Image or volume file (or DICOM folder)")->required();
  c.init_cmd->add_option("--template", i.tmpl, "Template: 3D mesh (.off .obj .ply .stl .vtk) or 2D contour (.txt .json .vtk)")->required();
  c.init_cmd->add_option("--reference", i.reference, "Reference image in which the template sits on its object (an atlas, the previous slice): the profile force's expected profiles");
  c.init_cmd->add_option("--mask", i.mask, "Ground truth: a label image (non-zero inside) or a surface file");
  c.init_cmd->add_option("--name", i.name, "Experiment name (default: the image's file name)");
  add_nifti_transform(c.init_cmd, c);
}

void add_template(CLI::App& app, CommandLine& c) {
  c.template_cmd = app.add_subcommand("template", "Make a template (3D mesh, 2D contour) from one label of a label image");
  TemplateCommandOptions& t = c.templ;
  c.template_cmd->add_option("--mask", t.mask, "Label image or volume file")->required();
  c.template_cmd->add_option("--label", t.label, "The label value N (voxels == N)")->required();
  c.template_cmd->add_option("--mirror", t.mirror, "Reflect about the symmetry plane normal to x, y or z (of the label map, or of --image)");
  c.template_cmd->add_option("--image", t.image, "With --mirror: find the symmetry plane in this image's intensities (same dimension as the label map)");
  c.template_cmd->add_option("--mirror-plane", t.mirror_plane, "Reflect about this plane, no search: AXIS=MM, e.g. x=0.5 (world mm, LPS; implies --mirror AXIS)");
  c.template_cmd->add_option("--vertices", t.vertices, "Vertex count (3D: within 10%; default 400)");
  c.template_cmd->add_option("--smoothing", t.smoothing, "Taubin smoothing steps before decimation (default 10)");
  c.template_cmd->add_flag("--allow-border", t.allow_border, "Accept a label touching the image border (flat cap)");
  add_nifti_transform(c.template_cmd, c);
  c.template_cmd->add_option("--out,-o", t.out, "3D: .off .obj .ply .stl .vtk; 2D: .txt .json .vtk")->required();
  c.template_cmd->add_option("--threads,-j", c.threads, "OpenMP threads (default: all cores)")->check(CLI::Range(1, 1024));
}

void add_sweep_and_schema(CLI::App& app, CommandLine& c) {
  c.sweep_cmd = app.add_subcommand(
      "sweep", "Run an experiment over methods x parameter grid x corruption levels x seeds (resumable)");
  SweepOptions& o = c.sweep;
  c.sweep_cmd->add_option("sweep", c.sweep_file, "Sweep file (JSON; format in experiments/sweep/sweep.h)")->required();
  c.sweep_cmd->add_option("--out,-o", o.out_dir, "Output folder (runs/, results.csv, breakdown.csv; default out/<sweep file name>)");
  c.sweep_cmd->add_option("--jobs,-j", o.jobs, "Runs at once (child processes; default 1)")->check(CLI::Range(1, 1024));
  c.sweep_cmd->add_option("--threads", o.threads, "OpenMP threads per run (default: the cores shared evenly among the -j jobs, at least 1)")
      ->check(CLI::Range(1, 1024));
  auto* manifest_opt =
      c.sweep_cmd
          ->add_option("--manifest", o.manifest,
                       "Write the unfinished runs for GNU parallel (manifest.txt) or Slurm (also sweep.slurm); run nothing")
          ->check(CLI::IsMember({"parallel", "slurm"}));
  c.sweep_cmd->add_option("--slurm-time", o.slurm.time_minutes, "Slurm: --time of each array task, minutes (default: from the finished runs)")
      ->check(CLI::Range(1, 525600));
  c.sweep_cmd->add_option("--slurm-mem", o.slurm.memory_mb, "Slurm: --mem of each array task, MB (default: from the finished runs)")
      ->check(CLI::Range(1, 100000000));
  c.sweep_cmd->add_option("--slurm-lines-per-task", o.slurm.lines_per_task,
                          "Slurm: runs per array task (default: about 5 minutes of the finished runs' median)")
      ->check(CLI::Range(1, 100000));
  c.sweep_cmd->add_option("--slurm-max-running", o.slurm.max_running, "Slurm: array tasks running at once (default: no cap)")
      ->check(CLI::Range(1, 100000));
  c.sweep_cmd->add_flag("--aggregate-only", o.aggregate_only, "Only rebuild results.csv, breakdown.csv and summary.*")->excludes(manifest_opt);
  c.sweep_cmd->add_flag("--keep-stale", o.keep_stale,
                        "Keep finished results made by another build or before an input file changed, instead of "
                        "running them again (results.csv's column stale marks them)");
  c.sweep_cmd->add_flag("--quiet,-q", o.quiet, "No progress lines on stderr");

  c.report_cmd = app.add_subcommand(
      "report", "Write report.html for a run's output folder (with its matplotlib figures), or for a sweep's: "
                "its summary tables (summary.csv, .md, .tex) from its results.csv, the Markdown one printed, and report.html");
  c.report_cmd->add_option("folder", c.report_folder, "A run's output folder (result.json) or a sweep's (results.csv)")->required();
  c.schema_cmd = app.add_subcommand(
      "schema", "Print the JSON Schema of experiment and sweep files (editors validate and complete with it)");
  c.schema_cmd->add_flag("--markdown", c.schema_markdown, "Print the key tables of docs/experiment-file.md instead");
}

int schema(bool markdown) {
  const std::string text = markdown ? experiment_reference_markdown() : experiment_schema().dump(2) + "\n";
  std::fwrite(text.data(), 1, text.size(), stdout);
  return 0;
}

int dispatch(const CommandLine& c) {
  if (c.threads > 0) omp_set_num_threads(c.threads);
  if (*c.run_cmd) return run(c.config, c.overrides, c.field_cache, c.run);
  if (*c.field_cmd) {
    FieldCommandOptions f = c.field;
    f.read = read_options_of(c.nifti_transform, f.image);
    return run_field_command(f);
  }
  if (*c.template_cmd) {
    TemplateCommandOptions t = c.templ;
    t.read = read_options_of(c.nifti_transform, t.mask);
    return run_template_command(t);
  }
  if (*c.init_cmd) {
    InitCommandOptions i = c.init;
    i.read = read_options_of(c.nifti_transform, i.image);
    return run_init_command(i);
  }
  if (*c.sweep_cmd) return sweep(c.sweep_file, c.sweep);
  if (*c.schema_cmd) return schema(c.schema_markdown);
  if (*c.report_cmd) return report(c.report_folder);
  if (*c.convert_cmd) {
    ConvertCommandOptions o = c.convert;
    o.read = read_options_of(c.nifti_transform, o.in);
    return run_convert_command(o);
  }
  return validate(c.validate_config, c.validate_overrides);
}

// OpenMP threads that wait without spinning, and large buffers on transparent huge pages.
// libgomp's threads spin for a while at every barrier before they sleep; when
// another process holds a core, a spinning thread takes the time its descheduled partner
// needs, and two threads run slower than one. glibc's malloc puts its large (mmap'd) blocks on
// huge pages with glibc.malloc.hugetlb=1 (madvise): a volume's first touch then takes one page
// fault per 2 MB instead of per 4 kB (the field of a 230 x 300 x 80 volume: 140 000 minor faults
// -> 12 000). Both are read from the environment once, when the libraries load, so a process
// started without them sets OMP_WAIT_POLICY=PASSIVE and GLIBC_TUNABLES=glibc.malloc.hugetlb=1
// and executes itself again (a few milliseconds). Settings the user made (OMP_WAIT_POLICY,
// GOMP_SPINCOUNT, GLIBC_TUNABLES) are kept. If the exec fails, the run goes on as it is.
void exec_with_process_settings(char** argv) {
  bool changed = false;
  if (std::getenv("OMP_WAIT_POLICY") == nullptr && std::getenv("GOMP_SPINCOUNT") == nullptr)
    changed |= setenv("OMP_WAIT_POLICY", "PASSIVE", 1) == 0;
  if (std::getenv("GLIBC_TUNABLES") == nullptr) changed |= setenv("GLIBC_TUNABLES", "glibc.malloc.hugetlb=1", 1) == 0;
  if (changed) execv("/proc/self/exe", argv);
}


}  // namespace

int main(int argc, char** argv) {
  exec_with_process_settings(argv);
  configure_heap(std::getenv("GLIBC_TUNABLES"));
  CLI::App app{"dsnake: register a template shape to an image or a volume with snake forces "
               "(D-Snake, Levi & Gotsman)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", dsnake_version());
  CommandLine c;
  add_run_and_validate(app, c);
  add_field(app, c);
  add_convert(app, c);
  add_template(app, c);
  add_init(app, c);
  add_sweep_and_schema(app, c);
  try {
    app.parse(argc, argv);
    c.run.command_line.assign(argv, argv + argc);  // result.json's provenance
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "dsnake: error: command line: %s (see dsnake --help)\n", e.what());
    return 2;
  }
  try {
    return dispatch(c);
  } catch (const InputError& e) {
    std::fprintf(stderr, "dsnake: error: %s\n", e.what());
    return 2;
  } catch (const OutputError& e) {  // a full disk, a read-only folder: not the input's fault
    std::fprintf(stderr, "dsnake: error: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dsnake: internal error: %s\n", e.what());
    return 1;
  }
}
