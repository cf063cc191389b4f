#pragma once
/// \file types.hpp
/// Scalar and array aliases used across maskadapt.
///
/// Conventions (see docs/architecture.md):
///  - batches are columns: a batch of feature vectors is a (features × batch) column-major matrix;
///  - networks and features are `float` by default and templated on the scalar;
///  - kinematics and simulator states are `double` (metres, seconds, radians; world is z-up);
///  - quaternions are Eigen's (coefficients stored x, y, z, w).
#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstdint>

namespace maskadapt {

using Index = Eigen::Index;

template <class T> using MatrixX = Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic>;
template <class T> using VectorX = Eigen::Matrix<T, Eigen::Dynamic, 1>;
template <class T> using RowVectorX = Eigen::Matrix<T, 1, Eigen::Dynamic>;

using MatrixXf = MatrixX<float>;
using VectorXf = VectorX<float>;
using MatrixXd = MatrixX<double>;
using VectorXd = VectorX<double>;

// Kinematics (double precision, world frame unless a name says otherwise).
using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using Quat = Eigen::Quaterniond;  // stored x, y, z, w
using Matrix3X = Eigen::Matrix<double, 3, Eigen::Dynamic>;

}  // namespace maskadapt
