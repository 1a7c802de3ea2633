// Block quadratic energies and their Jacobi / Gauss-Seidel coordinate steps; see block_quadratic.h.
// Levi & Gotsman, D-Snake, §4.1 eq. (5) and the Gauss-Seidel operator A2.
#include "energies/block_quadratic.h"

#include "framework/core/errors.h"

#include <Eigen/Dense>

namespace dsnake {

namespace {
constexpr int kDenseLimit = 2048;  // points; dense accumulation costs (D n)^2 doubles
}

template <int D>
void BlockQuadratic<D>::reset(int n) {
  n_ = n;
  dense_ = n <= kDenseLimit;
  rows_.clear();
  if (dense_) dense_h_ = Eigen::MatrixXd::Zero(D * n, D * n);
  else rows_.assign(n, {});
}

template <int D>
void BlockQuadratic<D>::add(int row, int col, const Block& b) {
  if (dense_) dense_h_.template block<D, D>(D * row, D * col) += b;
  else {
    auto [it, inserted] = rows_[row].try_emplace(col, Block::Zero());
    it->second += b;
  }
}

template <int D>
void BlockQuadratic<D>::add_residual(const std::vector<int>& vertices, const std::vector<Block>& blocks) {
  for (size_t a = 0; a < vertices.size(); ++a)
    for (size_t b = 0; b < vertices.size(); ++b) add(vertices[a], vertices[b], blocks[a].transpose() * blocks[b]);
}

template <int D>
void BlockQuadratic<D>::finalize() {
  offsets_.assign(1, 0);
  columns_.clear();
  blocks_.clear();
  diagonal_.assign(n_, Block::Zero());
  inverse_diagonal_.assign(n_, Block::Zero());
  active_.assign(n_, 0);
  double scale = 0.0;
  for (int k = 0; k < n_; ++k) {
    if (dense_) {
      for (int l = 0; l < n_; ++l) {
        const Block b = dense_h_.template block<D, D>(D * k, D * l);
        if (l == k) diagonal_[k] = b;
        else if (b.cwiseAbs().maxCoeff() > 0) { columns_.push_back(l); blocks_.push_back(b); }
      }
    } else {
      for (const auto& [l, b] : rows_[k]) {
        if (l == k) diagonal_[k] = b;
        else { columns_.push_back(l); blocks_.push_back(b); }
      }
    }
    offsets_.push_back(int(columns_.size()));
    scale = std::max(scale, diagonal_[k].trace());
  }
  for (int k = 0; k < n_; ++k) {
    // zero diagonal: the point does not appear in E (degenerate neighbourhood); it stays put
    if (diagonal_[k].trace() > 1e-12 * scale && std::abs(diagonal_[k].determinant()) > 0) {
      inverse_diagonal_[k] = diagonal_[k].inverse();
      active_[k] = 1;
    }
  }
  dense_h_.resize(0, 0);
  rows_.clear();
}

template <int D>
Point<D> BlockQuadratic<D>::off_diagonal_product(int k, const PointList<D>& q) const {
  Point<D> s = Point<D>::Zero();
  for (int e = offsets_[k]; e < offsets_[k + 1]; ++e) s.noalias() += blocks_[e] * q[columns_[e]];
  return s;
}

// Eq. (5): q(t+1) = A q(t), every point from the old positions of the others.
template <int D>
void BlockQuadratic<D>::jacobi(const PointList<D>& q, PointList<D>& out) const {
  DSNAKE_ASSERT(int(q.size()) == n_ && int(out.size()) == n_, "one point per row");
#pragma omp parallel for schedule(static) if (n_ >= 512)
  for (int k = 0; k < n_; ++k) out[k] = active_[k] ? Point<D>(-inverse_diagonal_[k] * off_diagonal_product(k, q)) : q[k];
}

// §4.1: A2 = (I - L)^{-1} (D + U): points in index order, each from the newest positions.
template <int D>
void BlockQuadratic<D>::gauss_seidel(PointList<D>& q) const {
  DSNAKE_ASSERT(int(q.size()) == n_, "one point per row");
  for (int k = 0; k < n_; ++k)
    if (active_[k]) q[k] = -inverse_diagonal_[k] * off_diagonal_product(k, q);
}

template <int D>
double BlockQuadratic<D>::value(const PointList<D>& q) const {
  double e = 0.0;
  for (int k = 0; k < n_; ++k) e += q[k].dot(diagonal_[k] * q[k] + off_diagonal_product(k, q));
  return e;
}

template class BlockQuadratic<2>;
template class BlockQuadratic<3>;

}  // namespace dsnake
