#include "framework/jacobian.hpp"

namespace sweep {

void pointJacobian(const Model& model, const Data& data, int body, const Vector3& point_world,
                   Eigen::Ref<Eigen::Matrix<double, 6, Eigen::Dynamic>> J) {
  forEachPointJacobianColumn(
      model, data, body, point_world,
      [&](int column, const Vector3& w, const Vector3& lin) { J.col(column) << w, lin; });
}

void frameJacobian(const Model& model, const Data& data, int body, const Pose& frame_in_body,
                   Eigen::Ref<Eigen::Matrix<double, 6, Eigen::Dynamic>> J) {
  pointJacobian(model, data, body, data.world_pose[body].apply(frame_in_body.translation), J);
}

}  // namespace sweep
