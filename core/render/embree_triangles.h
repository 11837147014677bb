// One Embree triangle geometry from a vertex and a triangle list: how
// Scene builds its meshes, shared with the benchmark that traces the same
// scene through bare Embree (bench/raw_embree.cc) so both hold the same
// buffers.
#pragma once

#include <vector>

#include <Eigen/Core>
#include <embree3/rtcore.h>

namespace relit::render {

// Adds the geometry to `target` (committed, and released to the scene).
void AttachTriangles(RTCDevice device, RTCScene target, const std::vector<Eigen::Vector3f>& positions,
                     const std::vector<Eigen::Vector3i>& triangles);

}  // namespace relit::render
