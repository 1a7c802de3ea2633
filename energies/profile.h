// The profile force: an active-shape-model search along the vertex normals (Cootes, Taylor,
// Cooper & Graham, "Active shape models - their training and application", CVIU 1995, §4.1 and
// the grey-level profile model of Cootes & Taylor 1993). For each vertex q with outward unit
// normal n, on the image smoothed by `sigma`:
//  - the profile at offset d is the derivative of the intensity along n, sampled every h mm over
//    [d - length, d + length] (2K differences of 2K + 1 samples, K = round(length / h)),
//    normalised to unit sum of absolute values, g(d) (ASM's normalised derivative profile: it
//    does not change with the image's intensity scale or offset, and it keeps the sign);
//  - its misfit is f(d) = |g(d) - g_expected|^2 (ASM's Mahalanobis distance with the identity
//    covariance: one expected profile, no training set); a flat profile (no derivative) has none;
//  - d runs over -search, ..., +search in steps of h; the best d* (smallest f, ties to the
//    smallest |d|, then the smaller d) is refined by a parabola through its neighbours' misfits;
//  - propose: q + step d* n (no profile anywhere: q); with min_improvement m > 0, q unless
//    f(d*) <= (1 - m) f(0): a vertex moves only on clear evidence. With max_travel r > 0, the
//    offsets searched are those whose point lies within r of where the template vertex stood when
//    the run started (its first bind), and the proposal is kept within that ball: without an atlas
//    image, the polarity learned from the start says nothing about edges farther away, and a
//    search that starts again from wherever the vertex has got to would let it walk from edge
//    to edge.
// The expected profile:
//  - with `template.reference_image` (EnergyContext::reference_image): sampled in that image
//    along the normals of the template at its rest positions p, as read from its file (the
//    template sits on its object there: an atlas, the previous slice; template.transform places
//    it in the target image). One profile per template vertex (reference_profile "per_vertex",
//    as ASM keeps one per landmark: a boundary's contrast varies along it), or their mean
//    ("mean": steadier on a noisy reference). A free vertex (added by remeshing, no template
//    vertex) takes the reference's profile at its rest position (energies/rest_positions.h: where
//    it was inserted, by the local similarity of its neighbours) along its normal turned into
//    the template's frame; vertices whose reference profile is flat take the mean;
//  - without one: a step edge of the given polarity blurred by max(sigma, h); "auto" learns one
//    polarity for all vertices at the first bind from the start (energies/polarity.h, band
//    `search`). With local_polarity, each template vertex learns its own instead (the inside-
//    minus-outside contrast along its normal at the start, over the band `search`, averaged over
//    its ring of neighbours), for a boundary whose contrast changes side (§7, Fig. 3: darker than
//    one neighbour, brighter than another); where that contrast is below the image's gradient
//    noise level times search / 2, the vertex has no expected profile and holds. A free vertex
//    takes the polarity of its nearest template vertex (along the mesh).
// Value: sum_v |g_v(0) - e_v|^2, each vertex's misfit where it stands (a flat window counts as
// g = 0, a vertex without an expected profile as 0): what the search lowers, for the energy trace
// and the run's total. Global view: none. The best offset is a discrete search, not a smooth
// function of q, so the term has no least-squares form ("solver": "global" refuses it).
#pragma once

#include "energies/polarity.h"
#include "framework/core/energy.h"
#include "framework/core/options.h"

#include <string>
#include <vector>

namespace dsnake {

// Where the expected profile comes from when there is a reference image.
enum class ReferenceProfile { kPerVertex, kMean };
template <>
struct EnumNames<ReferenceProfile> {
  static constexpr std::array<std::pair<ReferenceProfile, const char*>, 2> table{
      {{ReferenceProfile::kPerVertex, "per_vertex"}, {ReferenceProfile::kMean, "mean"}}};
};

struct ProfileOptions {
  double sigma = 1.0;    // mm
  double search = 5.0;   // mm
  double length = 3.0;   // mm
  double spacing = 0.0;  // mm; 0: half the smallest voxel size
  double step = 0.5;     // share of the offset per iteration
  EdgePolarity polarity = EdgePolarity::kAuto;
  ReferenceProfile reference_profile = ReferenceProfile::kPerVertex;
  bool local_polarity = false;
  double min_improvement = 0.0;  // 1
  double max_travel = 0.0;       // mm; 0: no bound

  template <class V>
  void visit(V& v) {
    v(sigma, Key{"sigma", "mm", "Gaussian smoothing of the image (and of the reference image) before sampling (0: none)",
                 Range::at_least(0)});
    v(search, Key{"search", "mm", "the offsets searched along each normal, -search to +search", Range::greater_than(0)});
    v(length, Key{"length", "mm", "half-length of the compared profile", Range::greater_than(0)});
    v(spacing, Key{"spacing", "mm", "sampling step along the normal (0: half the smallest voxel size)", Range::at_least(0)});
    v(step, Key{"step", "1", "share of the best offset moved per iteration", Range::open_closed(0, 1)});
    v(polarity, Key{"polarity", "", "without a reference image, the expected step edge: bright_inside, dark_inside, "
                                    "auto (one polarity learned from the start) or local (one per vertex, learned from "
                                    "the start); ignored with template.reference_image"});
    v(reference_profile, Key{"reference_profile", "", "with template.reference_image: one expected profile per template "
                                                      "vertex (per_vertex) or their mean (mean)"});
    v(min_improvement, Key{"min_improvement", "1", "a vertex moves only where its best misfit is at most (1 - this) "
                                                  "times its misfit where it stands (0: always)", Range::closed_open(0, 1)});
    v(max_travel, Key{"max_travel", "mm", "a template vertex is proposed no farther than this from where it stood when the "
                                         "run started: the evidence an edge gives without an atlas image is local "
                                         "(0: no bound)", Range::at_least(0)});
    v(local_polarity, Key{"local_polarity", "", "without a reference image: learn the polarity per vertex from the start "
                                                "(a boundary whose contrast changes side); vertices without a clear "
                                                "contrast hold; `polarity` is then not used"});
  }
};

template <int D>
class ProfileEnergy final : public Energy<D> {
 public:
  using Options = ProfileOptions;
  static constexpr const char* kType = "profile";
  static constexpr const char* kSummary =
      "active-shape-model profile search along the normals: q + step d* n, d* the best-matching offset";

  explicit ProfileEnergy(const ProfileOptions& options = {});
  std::string type() const override { return kType; }
  const ProfileOptions& options() const { return options_; }

  // Smooths the image (once per image), sets up the expected profiles (once: from the reference
  // image or the step edge; auto polarity learned from this first snake) and maps every snake
  // vertex to its expected profile. context.image must be set.
  void bind(const EnergyContext<D>& context, const Snake<D>& snake) override;
  // out[v] = q_v + step d*_v n_v for every vertex; parallel over vertices, the same bits for any
  // thread count (each vertex is computed alone).
  void propose(const Snake<D>& snake, PointList<D>& out) override;
  double value(const Snake<D>& snake) const override;  // the summed misfit at offset 0 (above)

  // The polarity of the step edge (after the first bind; kAuto with a reference image).
  EdgePolarity polarity() const { return polarity_; }
  // The best offset d* found for each vertex by the last propose(), mm along the normal.
  const std::vector<double>& offsets() const { return offsets_; }

 private:
  void set_up_expected(const EnergyContext<D>& context, const Snake<D>& snake);
  void set_up_free_vertices(const EnergyContext<D>& context, const Snake<D>& snake);
  void set_up_local_polarity(const EnergyContext<D>& context, const Snake<D>& snake);
  SmoothedImage<D> reference_;

  ProfileOptions options_;
  double h_ = 0.0;               // sampling step, mm
  int half_ = 0, reach_ = 0;     // K (profile half-length) and J (search) in steps of h
  SmoothedImage<D> image_;
  const Image<D>* expected_for_ = nullptr;  // the image the expected profiles were set up with
  EdgePolarity polarity_ = EdgePolarity::kAuto;
  std::vector<std::vector<double>> expected_;  // per template id (or one), 2K values each
  std::vector<std::vector<double>> free_expected_;  // per free vertex of the bound snake
  std::vector<double> mean_;                   // the mean expected profile
  std::vector<const std::vector<double>*> profile_of_;  // per snake vertex
  std::vector<double> offsets_;
  PointList<D> start_;             // per template id: its position at the first bind (max_travel)
  std::vector<int> template_of_;   // per snake vertex: its template id (-1: free)
  std::vector<double> scratch_;  // per vertex: 2(J + K) + 1 samples, 2J + 1 misfits, 2K + 1 samples
  PointList<D> normals_;
};

}  // namespace dsnake
