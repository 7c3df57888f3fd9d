#include "homography_teach_repeat/homography/homography_refinement.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/QR>

#include <cmath>
#include <limits>
#include <string>

namespace homography_teach_repeat {
namespace {

using Vector9d = Eigen::Matrix<double, 9, 1>;
using Matrix29d = Eigen::Matrix<double, 2, 9>;

// DLT rows of one match (docs/math.md §3.1).
Matrix29d dltRows(const Eigen::Vector3d& p, const Eigen::Vector2d& q) {
  Matrix29d a;
  a << 0.0, 0.0, 0.0, -p.transpose(), q.y() * p.transpose(), p.transpose(), 0.0, 0.0, 0.0,
      -q.x() * p.transpose();
  return a;
}

// Whitening W = L⁻¹ with B Bᵀ = L Lᵀ (B of docs/math.md §3.4 for h); false if B Bᵀ is singular.
bool sampsonWhitening(const Vector9d& h, const Eigen::Vector3d& p, const Eigen::Vector2d& q,
                      Eigen::Matrix2d* W) {
  const double h3p = h(6) * p.x() + h(7) * p.y() + h(8);
  Eigen::Matrix<double, 2, 4> b;
  b << -h(3) + q.y() * h(6), -h(4) + q.y() * h(7), 0.0, h3p, h(0) - q.x() * h(6),
      h(1) - q.x() * h(7), -h3p, 0.0;
  const Eigen::LLT<Eigen::Matrix2d> llt(b * b.transpose());
  if (llt.info() != Eigen::Success) return false;
  *W = llt.matrixL().solve(Eigen::Matrix2d::Identity());
  return W->allFinite();
}

struct Conditioned {
  std::vector<Eigen::Vector3d> reference;
  std::vector<Eigen::Vector2d> current;
  Eigen::Matrix3d T1, T2;  // p̂ = T p
  double scale = 1.0;
};

Conditioned condition(const PointMatches& matches) {
  Conditioned c;
  Eigen::Vector2d mean1 = Eigen::Vector2d::Zero(), mean2 = Eigen::Vector2d::Zero();
  for (const auto& m : matches) {
    mean1 += m.reference;
    mean2 += m.current;
  }
  mean1 /= static_cast<double>(matches.size());
  mean2 /= static_cast<double>(matches.size());
  double spread = 0.0;
  for (const auto& m : matches) spread += (m.reference - mean1).norm() + (m.current - mean2).norm();
  spread /= 2.0 * static_cast<double>(matches.size());
  c.scale = spread > 0.0 ? std::sqrt(2.0) / spread : 1.0;
  c.T1 << c.scale, 0, -c.scale * mean1.x(), 0, c.scale, -c.scale * mean1.y(), 0, 0, 1;
  c.T2 << c.scale, 0, -c.scale * mean2.x(), 0, c.scale, -c.scale * mean2.y(), 0, 0, 1;
  for (const auto& m : matches) {
    c.reference.push_back(c.T1 * m.reference.homogeneous());
    c.current.push_back((c.T2 * m.current.homogeneous()).template head<2>());
  }
  return c;
}

Vector9d toVector(const Eigen::Matrix3d& H) {
  Vector9d h;
  for (int k = 0; k < 9; ++k) h(k) = H(k / 3, k % 3);
  return h;
}

Eigen::Matrix3d toMatrix(const Vector9d& h) {
  Eigen::Matrix3d H;
  for (int k = 0; k < 9; ++k) H(k / 3, k % 3) = h(k);
  return H;
}

// Sampson cost (conditioned units) and optionally the normal equations.
bool evaluate(const Vector9d& h, const Conditioned& c, double* cost,
              Eigen::Matrix<double, 9, 9>* JtJ, Vector9d* Jtr) {
  *cost = 0.0;
  if (JtJ != nullptr) {
    JtJ->setZero();
    Jtr->setZero();
  }
  Eigen::Matrix2d W;
  for (std::size_t i = 0; i < c.reference.size(); ++i) {
    if (!sampsonWhitening(h, c.reference[i], c.current[i], &W)) return false;
    const Matrix29d J = W * dltRows(c.reference[i], c.current[i]);
    const Eigen::Vector2d r = J * h;
    *cost += r.squaredNorm();
    if (JtJ != nullptr) {
      JtJ->noalias() += J.transpose() * J;
      Jtr->noalias() += J.transpose() * r;
    }
  }
  return std::isfinite(*cost);
}

}  // namespace

double rmsSampsonDistance(const Eigen::Matrix3d& H, const PointMatches& matches) {
  if (matches.empty()) return std::numeric_limits<double>::quiet_NaN();
  double sum = 0.0;
  Eigen::Matrix2d W;
  const Vector9d h = toVector(H);
  for (const auto& m : matches) {
    const Eigen::Vector3d p = m.reference.homogeneous();
    if (!sampsonWhitening(h, p, m.current, &W)) return std::numeric_limits<double>::quiet_NaN();
    sum += (W * (dltRows(p, m.current) * h)).squaredNorm();
  }
  return std::sqrt(sum / static_cast<double>(matches.size()));
}

Expected<RefinedHomography> refineHomographySampson(const Eigen::Matrix3d& H,
                                                    const PointMatches& matches,
                                                    const HomographyRefinementOptions& options) {
  if (matches.size() < 4) {
    return Status(StatusCode::kTooFewPoints, "homography refinement needs at least 4 matches, got " +
                                                 std::to_string(matches.size()));
  }
  if (!H.allFinite() || !(H.norm() > 0.0)) {
    return Status(StatusCode::kInvalidInput, "initial homography is not finite or is zero");
  }
  if (options.max_iterations < 1 || !(options.relative_cost_tolerance >= 0.0)) {
    return Status(StatusCode::kInvalidInput, "refinement options: max_iterations >= 1");
  }
  for (const auto& m : matches) {
    if (!m.reference.allFinite() || !m.current.allFinite()) {
      return Status(StatusCode::kInvalidInput, "a match for the refinement is not finite");
    }
  }
  const Conditioned c = condition(matches);
  // Ĥ = T2 H T1⁻¹ in conditioned coordinates.
  Vector9d h = toVector(c.T2 * H * c.T1.inverse());
  h.normalize();
  double cost = 0.0;
  Eigen::Matrix<double, 9, 9> JtJ;
  Vector9d Jtr;
  if (!evaluate(h, c, &cost, &JtJ, &Jtr)) {
    return Status(StatusCode::kDegenerate, "a match is degenerate under the initial homography");
  }
  RefinedHomography result;
  const double to_pixels = 1.0 / (c.scale * c.scale);
  result.initial_rms_sampson_px = std::sqrt(cost * to_pixels / static_cast<double>(matches.size()));
  double lambda = 1e-4;
  int iteration = 0;
  for (; iteration < options.max_iterations; ++iteration) {
    // Tangent space of the unit sphere at h: the last 8 columns of a Householder basis.
    const Eigen::HouseholderQR<Vector9d> qr(h);
    const Eigen::Matrix<double, 9, 9> Q = qr.householderQ();
    const Eigen::Matrix<double, 9, 8> U = Q.rightCols<8>();
    const Eigen::Matrix<double, 8, 8> reduced = U.transpose() * JtJ * U;
    const Eigen::Matrix<double, 8, 1> gradient = U.transpose() * Jtr;
    bool improved = false;
    double new_cost = cost;
    for (int attempt = 0; attempt < 12 && !improved; ++attempt) {
      Eigen::Matrix<double, 8, 8> damped = reduced;
      damped.diagonal() += lambda * reduced.diagonal().cwiseMax(1e-12);
      const Eigen::LDLT<Eigen::Matrix<double, 8, 8>> ldlt(damped);
      if (ldlt.info() != Eigen::Success) break;
      const Vector9d candidate = (h - U * ldlt.solve(gradient)).normalized();
      Eigen::Matrix<double, 9, 9> candidate_JtJ;
      Vector9d candidate_Jtr;
      if (evaluate(candidate, c, &new_cost, &candidate_JtJ, &candidate_Jtr) && new_cost <= cost) {
        h = candidate;
        JtJ = candidate_JtJ;
        Jtr = candidate_Jtr;
        lambda = std::max(lambda * 0.1, 1e-12);
        improved = true;
      } else {
        lambda *= 10.0;
      }
    }
    if (!improved) break;
    const double decrease = cost - new_cost;
    cost = new_cost;
    if (decrease <= options.relative_cost_tolerance * (cost + 1e-300)) {
      ++iteration;
      break;
    }
  }
  Eigen::Matrix3d refined = c.T2.inverse() * toMatrix(h) * c.T1;
  refined /= refined.norm();
  if (!refined.allFinite()) return Status(StatusCode::kNotFinite, "refined homography is not finite");
  result.H = refined;
  result.rms_sampson_px = std::sqrt(cost * to_pixels / static_cast<double>(matches.size()));
  result.iterations = iteration;
  return result;
}

}  // namespace homography_teach_repeat
