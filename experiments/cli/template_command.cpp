// `dsnake template`; see template_command.h.
#include "experiments/cli/template_command.h"

#include "framework/core/errors.h"
#include "framework/io/image_io.h"
#include "framework/io/mesh_io.h"
#include "meshing/symmetry_plane.h"
#include "meshing/template_from_labels.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace dsnake {

namespace {

std::string axis_names(int dimension) { return dimension == 3 ? "x, y or z" : "x or y"; }

// The --mirror axis (-1 for none); z only for a volume.
int mirror_axis(const std::string& mirror, int dimension) {
  if (mirror.empty()) return -1;
  const std::string axes = dimension == 3 ? "xyz" : "xy";
  const size_t a = mirror.size() == 1 ? axes.find(mirror[0]) : std::string::npos;
  if (a == std::string::npos)
    throw InputError("", "--mirror " + mirror,
                     "must be " + axis_names(dimension) + " for a " + std::to_string(dimension) + "D label image");
  return int(a);
}

// The --mirror-plane option, AXIS=MM: a world axis (z only for a volume) and a finite offset.
MirrorPlane given_plane(const std::string& text, int dimension) {
  const std::string where = "--mirror-plane " + text, axes = dimension == 3 ? "xyz" : "xy";
  const size_t axis = text.size() > 2 && text[1] == '=' ? axes.find(text[0]) : std::string::npos;
  if (axis == std::string::npos)
    throw InputError("", where, "must be AXIS=MM with AXIS " + axis_names(dimension) + " (e.g. x=0.5)");
  const char* number = text.c_str() + 2;
  char* end = nullptr;
  const double offset = std::strtod(number, &end);
  if (end == number || *end != '\0' || !std::isfinite(offset))
    throw InputError("", where, "the offset after '=' must be a finite number of mm");
  return {int(axis), offset};
}

// Refuses a plane outside the label map (it would mirror the template out of the image).
template <int D>
void check_plane_inside(const MirrorPlane& p, const Grid<D>& labels, const std::string& file, const std::string& where) {
  const auto [lo, hi] = world_extent<D>(labels, p.axis);
  if (p.offset >= lo && p.offset <= hi) return;
  char buf[160];
  std::snprintf(buf, sizeof(buf), "the plane %c = %g mm lies outside the label map (%c from %g to %g mm)", "xyz"[p.axis],
                p.offset, "xyz"[p.axis], lo, hi);
  throw InputError(file, where, buf);
}

// Runs f, naming `option` in any InputError it throws (a file given to that option).
template <class F>
auto naming_option(const std::string& option, F&& f) {
  try {
    return f();
  } catch (const InputError& e) {
    throw InputError(e.file(), e.where().empty() ? option : option + ": " + e.where(), e.message());
  }
}

// The symmetry plane normal to `axis`: of the label map, or of --image's intensities.
template <int D>
MirrorPlane found_plane(const Image<D>& labels, int axis, const TemplateCommandOptions& c) {
  if (c.image.empty()) {
    if (!labels.grid().axis_aligned())
      throw InputError(c.mask, "--mirror", "the label map's grid is oblique: give the plane with --mirror-plane");
    try {
      return label_symmetry_plane<D>(labels, axis);
    } catch (const std::invalid_argument& e) {
      throw InputError(c.mask, "--mirror", e.what());
    }
  }
  const int dimension = naming_option("--image", [&] { return image_file_dimension(c.image); });
  if (dimension != D)
    throw InputError(c.image, "--image", "is a " + std::to_string(dimension) + "D image, the label map " +
                                             std::to_string(D) + "D: give an image of the label map's dimension");
  const Image<D> image = naming_option("--image", [&] { return read_image<D>(c.image, c.read); });
  if (!image.grid().axis_aligned())
    throw InputError(c.image, "--image", "the image's grid is oblique: give the plane with --mirror-plane");
  MirrorPlane plane;
  try {
    plane = image_symmetry_plane<D>(image, axis);
  } catch (const std::invalid_argument& e) {
    throw InputError(c.image, "--image", e.what());
  }
  check_plane_inside<D>(plane, labels.grid(), c.mask, "--image " + c.image);
  return plane;
}

// Refuses an output extension the shape's writer does not know, before any work is done.
void check_out_extension(const std::string& out, int dimension) {
  const std::vector<std::string> exts = dimension == 3 ? std::vector<std::string>{".off", ".obj", ".ply", ".stl", ".vtk"}
                                                       : std::vector<std::string>{".txt", ".json", ".vtk"};
  std::string known;
  for (const std::string& e : exts) {
    if (out.size() > e.size() && out.ends_with(e)) return;
    known += (known.empty() ? "" : " ") + e;
  }
  throw InputError(out, "--out", "unknown extension for a " + std::to_string(dimension) + "D template (use " + known + ")");
}

// The summary line: result, checks, Dice, and what the mask clean-up changed.
void print_summary(const std::string& out, const LabelTemplateOptions& o, int faces, const LabelTemplateReport& r,
                   int vertices, const std::string& mask, int dimension, const std::string& plane_source) {
  std::string notes;
  if (r.mask.components > 1)
    notes += "; kept the largest of " + std::to_string(r.mask.components) + " components (" +
             std::to_string(r.mask.kept_voxels) + " of " + std::to_string(r.mask.label_voxels) + " voxels)";
  if (r.mask.filled_voxels > 0) notes += "; filled " + std::to_string(r.mask.filled_voxels) + " enclosed voxels";
  if (r.mask.touches_border) notes += "; touches the image border (closed by a flat cap)";
  if (r.coarsened_spacing[0] > 0) {
    char buf[128];
    std::snprintf(buf, sizeof(buf), "; extracted on a coarser grid (spacing %.3g %.3g %.3g mm)", r.coarsened_spacing[0],
                  r.coarsened_spacing[1], r.coarsened_spacing[2]);
    notes += buf;
  }
  if (dimension == 3) notes += "; decimation attempt " + std::to_string(r.attempt);
  if (o.mirror) {
    char buf[96];
    std::snprintf(buf, sizeof(buf), "; mirrored about %c = %.2f mm (", "xyz"[o.mirror->axis], o.mirror->offset);
    notes += buf + plane_source + "; Dice before mirroring)";
  }
  std::printf("%s: %d vertices, %d %s, genus %d, %d self-intersections, Dice %.4f vs label %d of %s%s\n", out.c_str(),
              vertices, faces, dimension == 3 ? "faces" : "edges", r.genus, r.self_intersections, r.dice, o.label,
              mask.c_str(), notes.c_str());
}

template <int D>
int run(const TemplateCommandOptions& c) {
  LabelTemplateOptions o;
  o.label = c.label;
  o.vertices = c.vertices;
  const int axis = mirror_axis(c.mirror, D);
  std::optional<MirrorPlane> given;
  if (!c.mirror_plane.empty()) {
    given = given_plane(c.mirror_plane, D);
    if (axis >= 0 && given->axis != axis)
      throw InputError("", "--mirror-plane " + c.mirror_plane,
                       std::string("is normal to ") + "xyz"[given->axis] + ", --mirror to " + "xyz"[axis] +
                           ": give the same axis");
  }
  if (!c.image.empty() && axis < 0)
    throw InputError(c.image, "--image", "is only read to find the symmetry plane: give --mirror too");
  if (!c.image.empty() && given)
    throw InputError(c.image, "--image", "and --mirror-plane both set the plane: give one");
  o.smoothing_steps = c.smoothing;
  o.allow_border = c.allow_border;
  check_out_extension(c.out, D);
  if (c.smoothing < 0 || c.smoothing > 1000) throw InputError("", "--smoothing " + std::to_string(c.smoothing), "must be in [0, 1000]");
  if (c.vertices < kMinTemplateVertices || c.vertices > kMaxTemplateVertices)
    throw InputError("", "--vertices " + std::to_string(c.vertices),
                     "must be in [" + std::to_string(kMinTemplateVertices) + ", " + std::to_string(kMaxTemplateVertices) + "]");
  const Image<D> labels = read_image<D>(c.mask, c.read);
  std::string plane_source;
  if (given) {
    check_plane_inside<D>(*given, labels.grid(), c.mask, "--mirror-plane " + c.mirror_plane);
    o.mirror = given;
    plane_source = "given by --mirror-plane";
  } else if (axis >= 0) {
    o.mirror = found_plane<D>(labels, axis, c);
    plane_source = "symmetry plane of " + (c.image.empty() ? std::string("the label map") : c.image);
  }
  const LabelTemplate<D> t = template_from_labels<D>(labels, o, c.mask);
  write_shape<D>(t.shape.positions, t.shape.connectivity, c.out);
  const int faces = D == 3 ? int(t.shape.connectivity.triangles().size()) : t.shape.num_vertices();
  print_summary(c.out, o, faces, t.report, t.shape.num_vertices(), c.mask, D, plane_source);
  return 0;
}

}  // namespace

int run_template_command(const TemplateCommandOptions& options) {
  return image_file_dimension(options.mask) == 3 ? run<3>(options) : run<2>(options);
}

}  // namespace dsnake
