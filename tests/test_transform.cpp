// Affine inverses, handedness, normal matrices and conservative bounds,
// against hand-computed values.
#include <gtest/gtest.h>

#include <glm/gtc/matrix_transform.hpp>

#include "scene/transform.h"
#include "test_util.h"

namespace rayfold::core {
namespace {

TEST(Transform, InverseOfTranslateRotateScaleByHand) {
  // world_from_object = T(1,2,3) * Rz(90) * S(2,3,4): object (1,0,0) -> (1, 4, 3).
  Xform m = glm::translate(Xform(1.0), glm::dvec3(1, 2, 3));
  m = glm::rotate(m, M_PI / 2, glm::dvec3(0, 0, 1));
  m = glm::scale(m, glm::dvec3(2, 3, 4));
  const glm::dvec3 p = transform_point(m, glm::dvec3(1, 0, 0));
  EXPECT_NEAR(p.x, 1.0, 1e-12);
  EXPECT_NEAR(p.y, 4.0, 1e-12);
  EXPECT_NEAR(p.z, 3.0, 1e-12);
  Xform inv;
  ASSERT_TRUE(affine_inverse(m, &inv));
  const glm::dvec3 q = transform_point(inv, glm::dvec3(1, 4, 3));
  EXPECT_NEAR(q.x, 1.0, 1e-12);
  EXPECT_NEAR(q.y, 0.0, 1e-12);
  EXPECT_NEAR(q.z, 0.0, 1e-12);
  EXPECT_NEAR(linear_determinant(m), 24.0, 1e-12);
}

TEST(Transform, HandednessOfMirrors) {
  EXPECT_LT(linear_determinant(glm::scale(Xform(1.0), glm::dvec3(-1, 1, 1))), 0.0);
  EXPECT_GT(linear_determinant(glm::scale(Xform(1.0), glm::dvec3(-1, -1, 1))), 0.0);
  EXPECT_LT(linear_determinant(glm::scale(Xform(1.0), glm::dvec3(2, 3, -0.5))), 0.0);
}

TEST(Transform, SingularIsRejected) {
  Xform inv;
  EXPECT_FALSE(affine_inverse(glm::scale(Xform(1.0), glm::dvec3(1, 0, 1)), &inv));
  Xform nan_m(1.0);
  nan_m[3][0] = NAN;
  EXPECT_FALSE(affine_inverse(nan_m, &inv));
}

TEST(Transform, RowsLayoutByHand) {
  Xform m = glm::translate(Xform(1.0), glm::dvec3(5, 6, 7));
  m = glm::scale(m, glm::dvec3(2, 3, 4));
  float rows[12];
  to_rows3x4(m, rows);
  const float expected[12] = {2, 0, 0, 5, 0, 3, 0, 6, 0, 0, 4, 7};
  for (int i = 0; i < 12; ++i) EXPECT_EQ(rows[i], expected[i]) << i;
}

TEST(Transform, NormalMatrixOfNonUniformScaleByHand) {
  // Plane x + y = 0 scaled by (2, 1, 1) becomes x/2 + y = 0: normal ~ (1/2, 1, 0).
  float n[9];
  normal_matrix_rows3x3(glm::scale(Xform(1.0), glm::dvec3(2, 1, 1)), n);
  EXPECT_FLOAT_EQ(n[0], 0.5f);
  EXPECT_FLOAT_EQ(n[4], 1.0f);
  EXPECT_FLOAT_EQ(n[8], 1.0f);
  EXPECT_EQ(n[1], 0.0f);
  // A mirror keeps the normal on the same geometric side: the inverse
  // transpose of diag(-1, 1, 1) is diag(-1, 1, 1).
  normal_matrix_rows3x3(glm::scale(Xform(1.0), glm::dvec3(-1, 1, 1)), n);
  EXPECT_EQ(n[0], -1.0f);
}

TEST(Transform, ConservativeBoundsContainTransformedPoints) {
  testing::Rng rng(7);
  for (int trial = 0; trial < 200; ++trial) {
    Xform m = glm::translate(Xform(1.0), glm::dvec3(rng.uniform(-1e5, 1e5), rng.uniform(-10, 10), 0.0));
    m = glm::rotate(m, rng.uniform(0, 6.3), glm::normalize(glm::dvec3(rng.uniform(-1, 1), 1.0, rng.uniform(-1, 1))));
    m = glm::scale(m, glm::dvec3(rng.uniform(-3, 3), rng.uniform(0.1, 3), rng.uniform(0.1, 3)));
    Aabb b;
    b.grow(glm::vec3(rng.uniformf(-5, 0), rng.uniformf(-5, 0), rng.uniformf(-5, 0)));
    b.grow(glm::vec3(rng.uniformf(0, 5), rng.uniformf(0, 5), rng.uniformf(0, 5)));
    const Aabb t = transform_bounds_conservative(m, b);
    for (int i = 0; i < 50; ++i) {
      const glm::dvec3 p(rng.uniform(b.lo.x, b.hi.x), rng.uniform(b.lo.y, b.hi.y), rng.uniform(b.lo.z, b.hi.z));
      const glm::dvec3 q = transform_point(m, p);
      for (int k = 0; k < 3; ++k) {
        EXPECT_GE(q[k], t.lo[k]);
        EXPECT_LE(q[k], t.hi[k]);
      }
    }
  }
}

}  // namespace
}  // namespace rayfold::core
