// Example-based facial rigging (Li, Weise and Pauly 2010): personal blendshapes B_i from a
// person's neutral B_0 and expression scans P_k, starting from the template moved onto the
// person by deformation transfer (B_i^DT) and the scans' nominal weights alpha_k. Alternates
//
//   shapes:   min_B  sum_k ||B_0 + sum_i a_ik B_i - P_k||^2
//                   + beta sum_i sum_x w_i(x) ||B_i(x) - B_i^DT(x)||^2
//   weights:  min_{a_k in [0,1]^N}  ||B_0 + sum_i a_ik B_i - P_k||^2 + gamma ||a_k - alpha_k||^2
//
// with Li et al.'s per-vertex regularization weights w_i(x) = ((1 + d) / (kappa + d))^theta,
// d = ||S_i(x)|| / max_x ||S_i(x)|| the template shape's normalized displacement (vertices the
// template does not move are held to the transferred template). The shape step decouples
// per vertex (an N by N system each); the weight step is a bounded least squares per scan.
// Vectors and matrices are flattened per vertex as in template_shapes.h (3#V rows).
#ifndef FACECAP_ASSETS_EXAMPLE_BASED_RIGGING_H_
#define FACECAP_ASSETS_EXAMPLE_BASED_RIGGING_H_

#include <string>
#include <vector>

#include <Eigen/Core>

namespace facecap::assets {

struct ExampleBasedOptions {
  int iterations = 5;                 // shape / weight alternations
  float shape_regularization = 0.1f;  // beta: pull of B_i towards B_i^DT
  float kappa = 0.1f;                 // kappa of w_i(x)
  float theta = 2.f;                  // theta of w_i(x)
  float weight_regularization = 1.f;  // gamma (cm^2): pull of a_k towards alpha_k
  int threads = 1;                    // threads for the per-vertex shape step (<= 0: all)

  bool Check(std::string* why) const;
};

struct ExampleBasedResult {
  Eigen::MatrixXf deltas;    // B_i, 3#V by N (cm)
  Eigen::MatrixXf weights;   // a_k, K by N, the last weight step's estimate
};

// neutral: B_0 (3#V); expressions: P_k as columns (3#V by K); nominal_weights: alpha (K by N);
// transferred: B^DT (3#V by N); template_deltas: S_i (3#V by N), for w_i(x); vertices: the
// vertices solved for (others keep B^DT).
ExampleBasedResult FitExampleBasedRig(const Eigen::VectorXf& neutral,
                                      const Eigen::MatrixXf& expressions,
                                      const Eigen::MatrixXf& nominal_weights,
                                      const Eigen::MatrixXf& transferred,
                                      const Eigen::MatrixXf& template_deltas,
                                      const std::vector<int>& vertices,
                                      const ExampleBasedOptions& options);

// Rows 3v, 3v+1, 3v+2 of `m` for each v in `vertices`.
Eigen::MatrixXf SelectVertexRows(const Eigen::MatrixXf& m, const std::vector<int>& vertices);

// The reconstruction error of each expression with a set of shapes (paper 001 Table 2): the
// weights in [0, 1] that best fit P_k - B_0 over `vertices` (bounded least squares, the same
// solve for every method), then the mean distance ||B_0 + B w - P_k|| over those vertices (cm).
// Returns K errors; *weights (K by N) receives the solved weights when not null.
Eigen::VectorXd ReconstructionErrors(const Eigen::VectorXf& neutral, const Eigen::MatrixXf& deltas,
                                     const Eigen::MatrixXf& expressions,
                                     const std::vector<int>& vertices,
                                     Eigen::MatrixXf* weights = nullptr);

// Mean over shapes and `vertices` of ||A_i(x) - B_i(x)|| (cm): distance of a shape set to the
// true personal shapes.
double MeanShapeDistance(const Eigen::MatrixXf& a, const Eigen::MatrixXf& b,
                         const std::vector<int>& vertices);

}  // namespace facecap::assets

#endif  // FACECAP_ASSETS_EXAMPLE_BASED_RIGGING_H_
