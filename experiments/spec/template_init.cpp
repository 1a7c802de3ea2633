// "template.init": moments, landmark and image pre-alignment of the placed template; see template_init.h.
#include "experiments/spec/template_init.h"

#include "framework/core/errors.h"
#include "framework/io/image_io.h"

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <cmath>
#include <iostream>

namespace dsnake {

ImageAlignmentOptions TemplateInitOptions::alignment() const {
  ImageAlignmentOptions a;
  a.model = transform;
  a.margin = margin;
  a.levels = levels;
  a.iterations = iterations;
  a.max_scale = max_scale;
  return a;
}

ImageAlignmentOptions TemplateInitOptions::whole_image_alignment() const {
  ImageAlignmentOptions a = alignment();
  a.model = whole_image == WholeImageModel::kRigid    ? AlignmentModel::kRigid
            : whole_image == WholeImageModel::kAffine ? AlignmentModel::kAffine
                                                      : AlignmentModel::kSimilarity;
  a.margin = 0.0;
  a.levels = whole_image_levels;
  return a;
}

void TemplateInitOptions::check() const {
  if (type != TemplateInitType::kImage && transform == AlignmentModel::kAffine)
    throw OptionError{"transform", "\"affine\" only for \"type\": \"image\""};
  alignment().check();  // levels and max_scale: the alignment's own checks, under the same key names
  if (whole_image != WholeImageModel::kNone && type != TemplateInitType::kImage)
    throw OptionError{"whole_image", "only for \"type\": \"image\""};
  try {
    whole_image_alignment().check();
  } catch (const OptionError& e) {  // its levels are whole_image_levels
    throw OptionError{e.key == "levels" ? "whole_image_levels" : e.key, e.message};
  }
  if (type == TemplateInitType::kImage) {
    if (!mask.empty()) throw OptionError{"mask", "only for \"type\": \"moments\""};
    if (!threshold.empty()) throw OptionError{"threshold", "only for \"type\": \"moments\""};
    if (label) throw OptionError{"label", "only for \"type\": \"moments\""};
    if (!points.empty()) throw OptionError{"points", "only for \"type\": \"landmarks\""};
  } else if (type == TemplateInitType::kMoments) {
    if (mask.empty() == threshold.empty()) throw OptionError{"mask", "give exactly one of \"mask\" and \"threshold\""};
    if (!threshold.empty() && (threshold.size() != 2 || threshold[0] > threshold[1]))
      throw OptionError{"threshold", "expected [lo, hi] with lo <= hi"};
    if (label && mask.empty()) throw OptionError{"label", "only with \"mask\""};
    if (!points.empty()) throw OptionError{"points", "only for \"type\": \"landmarks\""};
  } else {
    if (points.empty()) throw OptionError{"points", "is required for \"type\": \"landmarks\""};
    if (!mask.empty()) throw OptionError{"mask", "only for \"type\": \"moments\""};
    if (!threshold.empty()) throw OptionError{"threshold", "only for \"type\": \"moments\""};
    if (label) throw OptionError{"label", "only for \"type\": \"moments\""};
  }
}

namespace {

// The region of "mask" (its label, or non-zero) or of "threshold" on the experiment's image.
template <int D>
Moments<D> target_moments(const TemplateInitOptions& o, const Image<D>& image, const std::string& file) {
  if (!o.mask.empty()) {
    const Image<D> mask = read_image<D>(o.mask, o.mask_read);
    const std::optional<int> label = o.label;
    const Moments<D> m = region_moments<D>(mask, [label](float v) { return label ? v == float(*label) : v != 0.0f; });
    if (m.measure == 0.0)
      throw InputError(file, label ? "template.init.label" : "template.init.mask",
                       "no voxel of " + o.mask + " is inside" + (label ? " (label " + std::to_string(*label) + ")" : ""));
    return m;
  }
  const double lo = o.threshold[0], hi = o.threshold[1];
  const Moments<D> m = region_moments<D>(image, [lo, hi](float v) { return v >= lo && v <= hi; });
  if (m.measure == 0.0) throw InputError(file, "template.init.threshold", "no voxel of the image is within the threshold");
  return m;
}

template <int D>
Similarity<D> init_by_moments(const TemplateInitOptions& o, const Template<D>& tmpl, const Image<D>& image,
                              const PointList<D>& placed, const std::string& file, InitReport<D>& report) {
  report.template_moments = enclosed_moments<D>(placed, tmpl.connectivity);
  if (!(report.template_moments.measure > 0)) throw InputError(file, "template", "the template encloses no area or volume");
  report.target_moments = target_moments<D>(o, image, file);
  Similarity<D> s = align_moments<D>(report.template_moments, report.target_moments, o.isotropy_tolerance, &report.axes_matched);
  if (o.transform == AlignmentModel::kRigid) {  // same rotation about the centroid, scale 1
    s.scale = 1.0;
    s.translation = report.target_moments.centroid - s.rotation * report.template_moments.centroid;
  }
  return s;
}

template <int D>
Similarity<D> init_by_landmarks(const TemplateInitOptions& o, const Template<D>& tmpl, const PointList<D>& placed,
                                const std::string& file, InitReport<D>& report) {
  PointList<D> from, to;
  std::vector<std::string> names;
  for (const auto& [name, p] : o.points) {
    const std::string where = "template.init.points." + name;
    const auto it = tmpl.landmarks.find(name);
    if (it == tmpl.landmarks.end()) {
      std::string known;
      for (const auto& [k, id] : tmpl.landmarks) known += (known.empty() ? "" : ", ") + k;
      throw InputError(file, where, "the template has no landmark \"" + name + "\" (its landmarks: " +
                                        (known.empty() ? "none; name them in template.landmarks" : known) + ")");
    }
    if (int(p.size()) != D) throw InputError(file, where, "expected " + std::to_string(D) + " numbers");
    names.push_back(name);
    from.push_back(placed[it->second]);
    to.push_back(Eigen::Map<const Point<D>>(p.data()));
  }
  if (const std::string problem = point_pairs_problem<D>(from, to); !problem.empty())
    throw InputError(file, "template.init.points", problem);
  const Similarity<D> s = fit_similarity<D>(from, to, o.transform == AlignmentModel::kSimilarity);
  if (!(s.scale > 0)) throw InputError(file, "template.init.points", "the points are matched by no similarity of positive scale");
  double sum = 0.0;
  for (size_t l = 0; l < names.size(); ++l) {
    const double r = (s.apply(from[l]) - to[l]).norm();
    report.residuals[names[l]] = r;
    report.residual_max = std::max(report.residual_max, r);
    sum += r * r;
  }
  report.residual_rms = std::sqrt(sum / double(names.size()));
  return s;
}

// The affine map taking `from` onto `to` in least squares (exact for the placement, a similarity
// of a template that spans the space).
template <int D>
AffineMap<D> fit_affine(const PointList<D>& from, const PointList<D>& to) {
  Point<D> cf = Point<D>::Zero(), ct = Point<D>::Zero();
  for (size_t i = 0; i < from.size(); ++i) cf += from[i], ct += to[i];
  cf /= double(from.size()), ct /= double(from.size());
  Eigen::Matrix<double, D, D> pp = Eigen::Matrix<double, D, D>::Zero(), qp = pp;
  for (size_t i = 0; i < from.size(); ++i) pp += (from[i] - cf) * (from[i] - cf).transpose(), qp += (to[i] - ct) * (from[i] - cf).transpose();
  AffineMap<D> m;
  m.matrix = qp * pp.completeOrthogonalDecomposition().pseudoInverse();
  m.translation = ct - m.matrix * cf;
  return m;
}

// The similarity nearest a matrix: scale |det|^(1/D), rotation its polar factor.
template <int D>
Similarity<D> nearest_similarity(const AffineMap<D>& m) {
  Similarity<D> s;
  s.scale = std::pow(std::abs(m.matrix.determinant()), 1.0 / D);
  const Eigen::JacobiSVD<Eigen::Matrix<double, D, D>> svd(m.matrix, Eigen::ComputeFullU | Eigen::ComputeFullV);
  s.rotation = svd.matrixU() * svd.matrixV().transpose();
  s.translation = m.translation;
  return s;
}

template <int D>
AffineMap<D> init_by_image(const TemplateInitOptions& o, const Template<D>& tmpl, const Image<D>& image, const Image<D>* reference,
                           const PointList<D>& placed, const std::string& file, InitReport<D>& report) {
  if (!reference) throw InputError(file, "template.init.type", "\"image\" needs template.reference_image (the atlas the template's file positions lie on)");
  WorldBox<D> region;
  region.lo = region.hi = tmpl.positions.front();
  for (const Point<D>& p : tmpl.positions) region.lo = region.lo.cwiseMin(p), region.hi = region.hi.cwiseMax(p);
  const AffineMap<D> placement = fit_affine<D>(tmpl.positions, placed);
  report.alignment = align_images<D>(*reference, image, region, placement, o.alignment());
  if (o.whole_image != WholeImageModel::kNone) {
    WholeImageAlignment<D> whole = align_whole_images<D>(*reference, image, placement, o.whole_image_alignment());
    if (whole.centred) {
      report.centroid_shift = whole.centroid_shift;
      report.whole_image = std::move(whole.fit);
      ImageAlignmentResult<D> from_whole = align_images<D>(*reference, image, region, report.whole_image->transform, o.alignment());
      if (from_whole.ncc_after > report.alignment.ncc_after) {
        report.alignment = std::move(from_whole);
        report.from_whole_image = true;
      }
    }
  }
  if (!report.alignment.warning.empty()) std::cerr << "warning: " << file << ": template.init: " << report.alignment.warning << "\n";
  // the template goes to T p = (T o P^-1)(P p): the map applied to the placed template
  return report.alignment.transform.after(placement.inverse());
}

nlohmann::ordered_json point_json(const Eigen::VectorXd& p) {
  nlohmann::ordered_json j = nlohmann::ordered_json::array();
  for (int a = 0; a < p.size(); ++a) j.push_back(p[a]);
  return j;
}

template <int D>
nlohmann::ordered_json moments_json(const Moments<D>& m) {
  return {{"measure", m.measure}, {"centroid", point_json(m.centroid)}};
}

nlohmann::ordered_json levels_json(const std::vector<AlignmentLevel>& levels) {
  nlohmann::ordered_json out = nlohmann::ordered_json::array();
  for (const AlignmentLevel& l : levels)
    out.push_back({{"sigma_mm", l.sigma}, {"stride", l.stride}, {"samples", l.samples}, {"iterations", l.iterations},
                   {"ncc_start", l.ncc_start}, {"ncc_end", l.ncc_end}});
  return out;
}

// The image alignment's fit: NCC before and after (on the finest level's smoothing), the share
// of the region inside the image, the steps, each level and a warning if the start was kept.
template <int D>
nlohmann::ordered_json image_fit_json(const InitReport<D>& r, nlohmann::ordered_json j) {
  const ImageAlignmentResult<D>& a = r.alignment;
  j["ncc_before"] = a.ncc_before;
  j["ncc_after"] = a.ncc_after;
  j["overlap"] = a.overlap;
  j["iterations"] = a.iterations;
  j["levels"] = levels_json(a.levels);
  if (!a.warning.empty()) j["warning"] = a.warning;
  if (r.whole_image) {
    const ImageAlignmentResult<D>& w = *r.whole_image;
    nlohmann::ordered_json matrix = nlohmann::ordered_json::array();
    for (int i = 0; i < D; ++i) matrix.push_back(point_json(w.transform.matrix.row(i).transpose()));
    nlohmann::ordered_json wj = {{"kept", r.from_whole_image},
                                 {"centroid_shift", point_json(r.centroid_shift)},
                                 {"matrix", matrix},
                                 {"translation", point_json(w.transform.translation)},
                                 {"ncc_before", w.ncc_before},
                                 {"ncc_after", w.ncc_after},
                                 {"overlap", w.overlap},
                                 {"iterations", w.iterations},
                                 {"levels", levels_json(w.levels)}};
    if (!w.warning.empty()) wj["warning"] = w.warning;
    j["whole_image"] = wj;
  }
  return j;
}

}  // namespace

template <int D>
InitReport<D> initialize_template(const TemplateInitOptions& options, const Template<D>& tmpl, const Image<D>& image,
                                  PointList<D>& placed, const std::string& file, const Image<D>* reference) {
  InitReport<D> report;
  report.type = options.type;
  report.model = options.transform;
  if (options.type == TemplateInitType::kImage) {
    report.map = init_by_image<D>(options, tmpl, image, reference, placed, file, report);
    report.transform = nearest_similarity<D>(report.map);
    // the template at T p, from the file positions (no round-off of the inverse placement)
    for (size_t i = 0; i < placed.size(); ++i) placed[i] = report.alignment.transform.apply(tmpl.positions[i]);
    return report;
  }
  report.transform = options.type == TemplateInitType::kMoments
                         ? init_by_moments<D>(options, tmpl, image, placed, file, report)
                         : init_by_landmarks<D>(options, tmpl, placed, file, report);
  report.map.matrix = report.transform.scale * report.transform.rotation;
  report.map.translation = report.transform.translation;
  for (auto& p : placed) p = report.transform.apply(p);
  return report;
}

template <int D>
nlohmann::ordered_json init_report_json(const InitReport<D>& r) {
  const Similarity<D>& s = r.transform;
  nlohmann::ordered_json rotation = nlohmann::ordered_json::array();
  for (int i = 0; i < D; ++i) rotation.push_back(point_json(s.rotation.row(i).transpose()));
  if (r.type == TemplateInitType::kImage && r.model == AlignmentModel::kAffine) {
    nlohmann::ordered_json matrix = nlohmann::ordered_json::array();
    for (int i = 0; i < D; ++i) matrix.push_back(point_json(r.map.matrix.row(i).transpose()));
    // the scale |det A|^(1/D) and the principal scales (A's singular values, largest first): how
    // much the template grew, and how unevenly
    const Eigen::Matrix<double, D, 1> principal = Eigen::JacobiSVD<Eigen::Matrix<double, D, D>>(r.map.matrix).singularValues();
    nlohmann::ordered_json j = {{"type", enum_name(r.type)},
                                {"transform", enum_name(r.model)},
                                {"matrix", matrix},
                                {"translation", point_json(r.map.translation)},
                                {"scale", std::pow(std::abs(r.map.matrix.determinant()), 1.0 / D)},
                                {"principal_scales", point_json(principal)}};
    return image_fit_json<D>(r, j);
  }
  nlohmann::ordered_json j = {{"type", enum_name(r.type)}, {"scale", s.scale}, {"rotation", rotation}};
  constexpr double kDeg = 180.0 / 3.14159265358979323846;
  if constexpr (D == 2) {
    j["rotation_deg"] = std::atan2(s.rotation(1, 0), s.rotation(0, 0)) * kDeg;
  } else {
    const Eigen::AngleAxisd aa(s.rotation);
    j["rotation_deg"] = aa.angle() * kDeg;
    j["rotation_axis"] = point_json(aa.axis());
  }
  j["translation"] = point_json(s.translation);
  if (r.type == TemplateInitType::kImage) {
    j["transform"] = enum_name(r.model);
    nlohmann::ordered_json matrix = nlohmann::ordered_json::array();
    for (int i = 0; i < D; ++i) matrix.push_back(point_json(r.map.matrix.row(i).transpose()));
    j["matrix"] = matrix;
    return image_fit_json<D>(r, j);
  }
  if (r.type == TemplateInitType::kLandmarks) {
    j["residual_rms_mm"] = r.residual_rms;
    j["residual_max_mm"] = r.residual_max;
    j["residuals_mm"] = r.residuals;
  } else {
    j["template"] = moments_json(r.template_moments);
    j["target"] = moments_json(r.target_moments);
    j["axes_matched"] = r.axes_matched;
  }
  return j;
}

template InitReport<2> initialize_template<2>(const TemplateInitOptions&, const Template<2>&, const Image<2>&, PointList<2>&,
                                              const std::string&, const Image<2>*);
template InitReport<3> initialize_template<3>(const TemplateInitOptions&, const Template<3>&, const Image<3>&, PointList<3>&,
                                              const std::string&, const Image<3>*);
template nlohmann::ordered_json init_report_json<2>(const InitReport<2>&);
template nlohmann::ordered_json init_report_json<3>(const InitReport<3>&);

}  // namespace dsnake
