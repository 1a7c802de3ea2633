// BlockQuadratic<D>: a quadratic energy E(q) = q^T H q over n points (H symmetric positive
// semi-definite, n x n blocks of D x D), with its coordinate-descent steps. This is the operator A
// of D-Snake eq. (5) (§4.1): minimising E over q_k with the others fixed gives
//   q_k <- -H_kk^{-1} sum_{l != k} H_kl q_l,
// so A = I - blockdiag(H)^{-1} H (Jacobi) and A2 = (I - L)^{-1} (D + U) (Gauss-Seidel, which
// never increases E). Used by the exact 2D ASAP energy and the Laplacian editing energy.
#pragma once

#include "framework/core/types.h"

#include <Eigen/Core>
#include <map>
#include <vector>

namespace dsnake {

template <int D>
class BlockQuadratic {
 public:
  using Block = Eigen::Matrix<double, D, D>;

  // Starts an empty H over n points (dense accumulation when n is small, else per-row maps).
  void reset(int n);
  void add(int row, int col, const Block& b);  // H_row,col += b
  // Adds r^T r for the residual r = sum_k blocks[k] q_{vertices[k]} (H += C^T C).
  void add_residual(const std::vector<int>& vertices, const std::vector<Block>& blocks);
  // Compresses to block rows and inverts the diagonal blocks; a vertex whose diagonal block is
  // (numerically) zero does not appear in E and stays where it is.
  void finalize();

  int size() const { return n_; }
  void jacobi(const PointList<D>& q, PointList<D>& out) const;  // out = A q
  void gauss_seidel(PointList<D>& q) const;                     // q <- A2 q, in place, in index order
  double value(const PointList<D>& q) const;                    // q^T H q
  const Block& diagonal(int k) const { return diagonal_[k]; }

 private:
  Point<D> off_diagonal_product(int k, const PointList<D>& q) const;  // sum_{l != k} H_kl q_l

  int n_ = 0;
  bool dense_ = false;
  Eigen::MatrixXd dense_h_;                    // during accumulation, small n
  std::vector<std::map<int, Block>> rows_;     // during accumulation, large n
  std::vector<int> offsets_{0}, columns_;      // finalized off-diagonal block rows
  std::vector<Block, Eigen::aligned_allocator<Block>> blocks_, diagonal_, inverse_diagonal_;
  std::vector<char> active_;
};

}  // namespace dsnake
