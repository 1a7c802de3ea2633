// The patch force: the atlas's appearance at every vertex, matched by normalised cross-
// correlation (NCC) and followed by a Gauss-Newton (Lucas-Kanade) step. It needs an atlas image
// (template.reference_image, EnergyContext::reference_image) in which the template at its rest
// positions lies on its object. The active-shape model's grey-level model (Cootes et al., CVIU
// 1995, §4.1) keeps one expected profile per landmark along its normal; here every vertex keeps a
// small D-dimensional patch, so that it also sees along the boundary (block matching, Ourselin
// et al. 2000), and every vertex has its own, including the free vertices that remeshing inserts:
// their patches come from their rest positions (energies/rest_positions.h), never from a mean.
//
// For a vertex v with rest position p_v (reference frame) and current position q_v:
//  - the expected patch e_v: the smoothed reference at p_v + L_v^{-1} h k, k in {-K..K}^D
//    (K = round(radius / h)), with its mean removed and unit norm, so that it covers the same
//    anatomy as the scan's axis-aligned patch below. L_v is v's local linear map from the rest
//    shape to the snake: the least-squares affine map of v's neighbourhood (v, its one-ring and
//    the vertices reached along edges whose rest positions lie within `map_radius` of v's and
//    whose rest normals lie within 90 degrees of v's: one side of a thin part) from
//    their rest positions to their current positions, regularised towards their similarity
//    (Umeyama) by lambda = 0.05 of the mean squared spread, so that the direction a surface
//    cannot show (its normal) takes the similarity's scale. The as-similar-as-possible model
//    (§4) lets a template stretch and shear a little everywhere; a patch matched by translation
//    alone is biased by as much as that stretch moves its features across its radius. L_v is
//    refitted at every propose() and the patch resampled where it changed by more than 0.01.
//    With map_radius = 0, one L for all vertices: the linear part of the affine map of all
//    deformation vertices at bind (the placement: template.transform, template.init);
//  - the scan's patch s(q) at q_v + h k (smoothed scan), with its mean removed: s';
//    NCC = e . s' / |s'| (1 where the scan is the atlas up to a positive linear change of
//    contrast a I + b, a > 0);
//  - the move delta minimises |e - a (s' + G' delta)|^2 with a = e . s' / |s'|^2 held (the
//    contrast, in closed form) and G' the centred gradients of the scan at the patch's points
//    (central differences of the samples one ring further out): (G'^T G' + lambda I) delta =
//    G'^T (e - a s') / a, lambda = damping * trace(G'^T G') / D (Levenberg: along a straight
//    boundary the patch only says where the boundary is, and delta follows the normal);
//    |delta| <= max_step. With `gradient` atlas, G' is replaced by the expected patch's own
//    centred differences divided by a (inverse compositional: Baker & Matthews, IJCV 2004; noise-free
//    where the atlas is an average); with both, by the mean of the two (efficient second-order
//    minimisation: Benhimane & Malis, IROS 2004); scan is the forward step above. With atlas and
//    both, a = 1 / (e . s'): the scan's patch fitted on the atlas's, which noise in the scan does
//    not bias (e . s' / |s'|^2 takes the noise in |s'|^2 and shortens the step by about NCC^2);
//  - propose: q + step delta where NCC >= min_correlation and a > 0; elsewhere q (the vertex holds:
//    no consistent evidence there, and the regularisers move it).
// The contrast's sign: a linear change of contrast a I + b may have a < 0 (an atlas in T1, a scan
// in T2: fluid dark in one, bright in the other; the image init, framework/core/image_alignment.h,
// fits a of either sign). With `contrast` negative every expected patch is negated, so that
// NCC, a and the step above read the same; auto takes the sign of the sum over vertices of their
// NCC with the positive patches where the vertices are at bind (a phase's start), summed in
// vertex order (the same sign for any thread count).
// The smoothing: the scan is smoothed by sigma in its frame, and with `smoothing` image the atlas
// by sigma in its own. Through a map L that stretches, the scan's blur seen in the atlas is the
// anisotropic sigma^2 L^-1 L^-T, not sigma^2 I: edges compared through L are blurred differently,
// which moves the best match off the truth, the more the larger sigma and the stretch
// (REPRODUCTION.md, "Started at the peers' results or at the truth"). With `mapped` the atlas is
// smoothed by 0.8 sigma and the rest, sigma^2 L^-1 L^-T - (0.8 sigma)^2 I (clamped at 0 along
// directions L stretches by more than 1 / 0.8), by Gauss-Hermite quadrature at every sample of
// the expected patch (three nodes per eigen-direction, 3^D samples of the atlas per point).
// The search is coarse to fine across phases: a large sigma and radius in the fit phase, small
// ones in the refine phase (experiments/real/recipe_3d.json).
// Global view: value() = sum over vertices of (1 - NCC_v) (0 at a perfect match), defined at every
// q; no least-squares form (NCC is a ratio), so "solver": "global" refuses it.
#pragma once

#include "energies/polarity.h"
#include "framework/core/energy.h"
#include "framework/core/options.h"

#include <string>
#include <vector>

namespace dsnake {

enum class PatchContrast { kAuto, kPositive, kNegative };
template <>
struct EnumNames<PatchContrast> {
  static constexpr std::array<std::pair<PatchContrast, const char*>, 3> table{
      {{PatchContrast::kAuto, "auto"}, {PatchContrast::kPositive, "positive"}, {PatchContrast::kNegative, "negative"}}};
};

enum class PatchGradient { kScan, kAtlas, kBoth };
template <>
struct EnumNames<PatchGradient> {
  static constexpr std::array<std::pair<PatchGradient, const char*>, 3> table{
      {{PatchGradient::kScan, "scan"}, {PatchGradient::kAtlas, "atlas"}, {PatchGradient::kBoth, "both"}}};
};

// How the atlas patch is smoothed (sigma): in the atlas's own frame, as the scan is in its own;
// or with the scan's smoothing pulled back through the vertex's map, so that a patch compared
// through a stretched map carries the same blur as the scan's.
enum class PatchSmoothing { kImage, kMapped };
template <>
struct EnumNames<PatchSmoothing> {
  static constexpr std::array<std::pair<PatchSmoothing, const char*>, 2> table{
      {{PatchSmoothing::kImage, "image"}, {PatchSmoothing::kMapped, "mapped"}}};
};

struct PatchOptions {
  double sigma = 1.0;             // mm
  double radius = 3.0;            // mm
  double spacing = 0.0;           // mm; 0: the image's smallest voxel size
  double min_correlation = 0.5;   // 1
  double damping = 0.1;           // 1
  double max_step = 0.0;          // mm; 0: the sampling step
  double step = 1.0;              // 1
  double map_radius = 6.0;        // mm
  PatchContrast contrast = PatchContrast::kAuto;
  PatchGradient gradient = PatchGradient::kScan;
  PatchSmoothing smoothing = PatchSmoothing::kImage;

  template <class V>
  void visit(V& v) {
    v(sigma, Key{"sigma", "mm", "Gaussian smoothing of the image and of the atlas image before sampling (0: none)",
                 Range::at_least(0)});
    v(radius, Key{"radius", "mm", "half-width of the compared patch (a cube, or a square in 2D)", Range::greater_than(0)});
    v(spacing, Key{"spacing", "mm", "distance between the patch's samples (0: the image's smallest voxel size)",
                   Range::at_least(0)});
    v(min_correlation, Key{"min_correlation", "1", "vertices whose patch correlates less than this with the atlas's "
                                                   "hold (no evidence to follow)", Range::closed_open(-1, 1)});
    v(damping, Key{"damping", "1", "Levenberg damping of the Gauss-Newton step, relative to the mean eigenvalue",
                   Range::at_least(0)});
    v(max_step, Key{"max_step", "mm", "longest move proposed per iteration (0: the sampling step)", Range::at_least(0)});
    v(step, Key{"step", "1", "share of the Gauss-Newton move proposed per iteration", Range::open_closed(0, 1)});
    v(map_radius, Key{"map_radius", "mm", "each vertex's atlas patch follows the local affine map of the vertices within "
                                          "this distance of it on the template and on its side (rest normals within 90 degrees of "
                                          "its own; and its one-ring), from their rest positions to where they are (0: one map "
                                          "for all, the placement's)",
                      Range::at_least(0)});
    v(contrast, Key{"contrast", "", "sign of the linear change of contrast from the atlas to the scan: positive, negative "
                                    "(e.g. a T1 atlas and a T2 scan), or auto: the sign of the vertices' summed correlation "
                                    "where the phase starts"});
    v(gradient, Key{"gradient", "", "the Gauss-Newton step's gradients: the scan's (forward), the atlas patch's (inverse) or their mean (both)"});
    v(smoothing, Key{"smoothing", "", "the atlas patch's smoothing: image (the atlas smoothed by sigma in its own frame) or mapped (the scan's isotropic sigma pulled back through the vertex's map, so that a stretched map compares equally blurred patches; 3^D atlas samples per patch point where a patch is resampled)"});
  }
};

template <int D>
class PatchEnergy final : public Energy<D> {
 public:
  using Options = PatchOptions;
  static constexpr const char* kType = "patch";
  static constexpr const char* kSummary =
      "the atlas image's patch at every vertex's rest position, matched by normalised cross-correlation "
      "(Gauss-Newton step); needs template.reference_image";

  explicit PatchEnergy(const PatchOptions& options = {});
  std::string type() const override { return kType; }
  bool needs_reference_image() const override { return true; }
  const PatchOptions& options() const { return options_; }

  // Smooths both images (once), fits the placement's linear part and finds every vertex's rest
  // position; the expected patches are sampled there on first use (propose, value). context.image and context.reference_image must be set.
  void bind(const EnergyContext<D>& context, const Snake<D>& snake) override;
  // out[v] as above; parallel over vertices, the same bits for any thread count.
  void propose(const Snake<D>& snake, PointList<D>& out) override;
  double value(const Snake<D>& snake) const override;

  // Each vertex's expected patch (empty when the atlas is flat there), (2K + 1)^D values with the
  // first axis fastest, mean removed and unit norm; and the NCC of the last propose().
  const std::vector<std::vector<double>>& expected() const {
    set_up_expected();
    return expected_;
  }
  const std::vector<double>& correlations() const { return correlation_; }
  // +1 or -1: the contrast's sign the expected patches were sampled with (after first use).
  int contrast_sign() const { return sign_; }
  double sampling_step() const { return h_; }
  int half_width() const { return half_; }
  // The linear part L of the placement found at the last bind (reference frame -> image frame).
  const Eigen::Matrix<double, D, D>& placement_linear() const { return linear_; }
  // Vertex v's local linear map L_v its expected patch was last sampled with (map_radius > 0), or L.
  const Eigen::Matrix<double, D, D>& patch_map(int v) const { return options_.map_radius > 0 ? maps_[v] : linear_; }

 private:
  // NCC of vertex v's expected patch with the scan at x; with `move`, also the Gauss-Newton move.
  double match(int v, const Point<D>& x, Point<D>* move, double* scratch) const;

  PatchOptions options_;
  double h_ = 0.0;
  int half_ = 0;
  int count_ = 0;  // (2K + 1)^D
  std::vector<int> outer_;  // inner patch point k -> its index in the lattice one ring wider
  SmoothedImage<D> image_, reference_;
  Eigen::Matrix<double, D, D> linear_ = Eigen::Matrix<double, D, D>::Identity();
  // Samples the expected patches on first use after bind; with contrast auto, the sign from the
  // vertices' correlations where they were at bind.
  void set_up_expected() const;
  // The expected patch of vertex v through the linear map m (empty when flat).
  std::vector<double> sample_expected(int v, const Eigen::Matrix<double, D, D>& m) const;
  // L_v from the current positions q (map_radius > 0).
  Eigen::Matrix<double, D, D> local_map(int v, const PointList<D>& q) const;
  PointList<D> rest_frame_;  // per snake vertex: its rest position in the reference image's frame
  PointList<D> bound_at_;    // per snake vertex: where it was at bind (contrast auto)
  mutable std::vector<std::vector<double>> expected_;  // per snake vertex, sampled on first use
  std::vector<double> correlation_;
  mutable int sign_ = 1;
  std::vector<int> ring_offsets_, ring_;  // per vertex: its neighbourhood for L_v, v first
  mutable std::vector<Eigen::Matrix<double, D, D>> maps_;  // per vertex: the L_v its patch was sampled with
};

// The k-th offset (in steps h) of a patch of half-width K: k = sum_d (k_d + K) (2K + 1)^d.
template <int D>
Point<D> patch_offset(int k, int half);

}  // namespace dsnake
