// `dsnake template`; see template_command.h.
#include "experiments/template_command.h"

#include "framework/core/errors.h"
#include "framework/io/image_io.h"
#include "framework/io/mesh_io.h"
#include "meshing/template_from_labels.h"

#include <cstdio>
#include <string>
#include <vector>

namespace dsnake {

namespace {

// The --mirror axis (-1 for none); z only for a volume.
int mirror_axis(const std::string& mirror, int dimension) {
  if (mirror.empty()) return -1;
  const std::string axes = dimension == 3 ? "xyz" : "xy";
  const size_t a = mirror.size() == 1 ? axes.find(mirror[0]) : std::string::npos;
  if (a == std::string::npos)
    throw InputError("", "--mirror " + mirror, std::string("must be ") + (dimension == 3 ? "x, y or z" : "x or y") +
                                                   " for a " + std::to_string(dimension) + "D label image");
  return int(a);
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
                   int vertices, const std::string& mask, int dimension) {
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
  if (o.mirror_axis >= 0) notes += std::string("; mirrored in ") + "xyz"[o.mirror_axis] + " (Dice before mirroring)";
  std::printf("%s: %d vertices, %d %s, genus %d, %d self-intersections, Dice %.4f vs label %d of %s%s\n", out.c_str(),
              vertices, faces, dimension == 3 ? "faces" : "edges", r.genus, r.self_intersections, r.dice, o.label,
              mask.c_str(), notes.c_str());
}

template <int D>
int run(const TemplateCommandOptions& c) {
  LabelTemplateOptions o;
  o.label = c.label;
  o.vertices = c.vertices;
  o.mirror_axis = mirror_axis(c.mirror, D);
  o.smoothing_steps = c.smoothing;
  o.allow_border = c.allow_border;
  check_out_extension(c.out, D);
  if (c.smoothing < 0 || c.smoothing > 1000) throw InputError("", "--smoothing " + std::to_string(c.smoothing), "must be in [0, 1000]");
  if (c.vertices < kMinTemplateVertices || c.vertices > kMaxTemplateVertices)
    throw InputError("", "--vertices " + std::to_string(c.vertices),
                     "must be in [" + std::to_string(kMinTemplateVertices) + ", " + std::to_string(kMaxTemplateVertices) + "]");
  const LabelTemplate<D> t = template_from_labels<D>(read_image<D>(c.mask, c.read), o, c.mask);
  write_shape<D>(t.shape.positions, t.shape.connectivity, c.out);
  const int faces = D == 3 ? int(t.shape.connectivity.triangles().size()) : t.shape.num_vertices();
  print_summary(c.out, o, faces, t.report, t.shape.num_vertices(), c.mask, D);
  return 0;
}

}  // namespace

int run_template_command(const TemplateCommandOptions& options) {
  return image_file_dimension(options.mask) == 3 ? run<3>(options) : run<2>(options);
}

}  // namespace dsnake
