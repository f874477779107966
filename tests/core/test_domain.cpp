// The map's target domain (core/domain.h): known answers for every kind.
#include <gtest/gtest.h>

#include <cmath>

#include "core/domain.h"
#include "core/error.h"

namespace authalic {
namespace {

TEST(Domain, ExtentAreaAndElementGridOfEachKind) {
  EXPECT_EQ(Domain::square().width(), 1.0);
  EXPECT_EQ(Domain::rectangle().width(), 2.0);
  EXPECT_EQ(Domain::rectangle().area(), 2.0);
  EXPECT_NEAR(Domain::sphere().area(), 4 * M_PI, 1e-15);
  EXPECT_EQ(Domain::square().element_cols(32), 32);
  EXPECT_EQ(Domain::rectangle().element_cols(32), 64);
  EXPECT_EQ(Domain::sphere().element_cols(32), 64);
  EXPECT_EQ(Domain::sphere().element_rows(32), 32);
  EXPECT_FALSE(Domain::sphere().planar());
  EXPECT_EQ(Domain::square().perimeter(), 4.0);
  EXPECT_EQ(Domain::rectangle().perimeter(), 6.0);
}

TEST(Domain, NamesRoundTripAndAnUnknownNameIsRefusedNamingTheSource) {
  for (DomainKind k : {DomainKind::Square, DomainKind::Rectangle, DomainKind::Sphere, DomainKind::Disk})
    EXPECT_EQ(parse_domain_kind(to_string(k), "x"), k);
  EXPECT_EQ(parse_domain_kind("rect", "x"), DomainKind::Rectangle);
  try {
    parse_domain_kind("disc", "map.json: domain");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "map.json: domain: unknown domain 'disc'; use square, rectangle, sphere or disk");
  }
}

TEST(Domain, BoundaryParametrisationVisitsTheCornersCounterClockwise) {
  const Domain r = Domain::rectangle();
  EXPECT_TRUE(r.boundary_point(0.0).isApprox(Eigen::Vector2d(0, 0)));
  EXPECT_TRUE(r.boundary_point(2.0).isApprox(Eigen::Vector2d(2, 0)));
  EXPECT_TRUE(r.boundary_point(3.0).isApprox(Eigen::Vector2d(2, 1)));
  EXPECT_TRUE(r.boundary_point(5.0).isApprox(Eigen::Vector2d(0, 1)));
  EXPECT_TRUE(r.boundary_point(6.5).isApprox(Eigen::Vector2d(0.5, 0)));  // wraps
  EXPECT_TRUE(r.boundary_point(-0.5).isApprox(Eigen::Vector2d(0, 0.5)));
  // The anchors: the frontal pole of a hemisphere at the top middle, the whole brain's anterior
  // landmark at the middle of the left side.
  EXPECT_TRUE(rectangle_perimeter_point(rectangle_top_middle(1.0), 1.0).isApprox(Eigen::Vector2d(0.5, 1)));
  EXPECT_TRUE(rectangle_perimeter_point(rectangle_top_middle(1.5), 1.5).isApprox(Eigen::Vector2d(0.75, 1)));
  EXPECT_TRUE(rectangle_perimeter_point(rectangle_left_middle(2.0), 2.0).isApprox(Eigen::Vector2d(0, 0.5)));
  EXPECT_EQ(rectangle_side(0.5, 2.0), kSideBottom);
  EXPECT_EQ(rectangle_side(2.5, 2.0), kSideRight);
  EXPECT_EQ(rectangle_side(4.0, 2.0), kSideTop);
  EXPECT_EQ(rectangle_side(5.5, 2.0), kSideLeft);
}

TEST(Domain, ConstrainClampsOntoThePlaneOrProjectsOntoTheSphere) {
  EXPECT_TRUE(Domain::square().constrain({1.5, -0.2, 3}).isApprox(Eigen::Vector3d(1, 0, 0)));
  EXPECT_TRUE(Domain::rectangle().constrain({1.5, 0.5, 0}).isApprox(Eigen::Vector3d(1.5, 0.5, 0)));
  EXPECT_TRUE(Domain::sphere().constrain({0, 3, 4}).isApprox(Eigen::Vector3d(0, 0.6, 0.8)));
  EXPECT_TRUE(Domain::sphere().constrain({0, 0, 0}).isApprox(Eigen::Vector3d(0, 0, 1)));
}

TEST(Domain, ElementOfAPointOnEachKind) {
  const double p[3] = {1.49, 0.76, 0};
  EXPECT_EQ(Domain::rectangle().element_of_point(2, p), 1 * 4 + 2);  // 4 x 2 cells of 0.5
  const double q[3] = {0.99, 0.01, 0};
  EXPECT_EQ(Domain::square().element_of_point(2, q), 1);
  const double outside[3] = {7, 7, 0};
  EXPECT_EQ(Domain::square().element_of_point(2, outside), 3);  // clamped onto the corner cell
  // Sphere: longitude -pi at column 0; the point (1, 0, 0) has longitude 0: column cols / 2; z = 0
  // is the edge between the bands k/2 - 1 and k/2.
  const double east[3] = {2, 0, 0.01};
  EXPECT_EQ(Domain::sphere().element_of_point(4, east), 2 * 8 + 4);
}

TEST(Domain, ElementOverlapOfAWholeDomainCoversItsArea) {
  // Two triangles covering the rectangle: the pieces' areas add up to 2, each cell 2 / (4 x 2).
  MatrixXd UV(4, 2);
  UV << 0, 0, 2, 0, 2, 1, 0, 1;
  MatrixXi F(2, 3);
  F << 0, 1, 2, 0, 2, 3;
  const auto pieces = Domain::rectangle().element_overlap(UV, F, 2);
  std::vector<double> cell(8, 0.0);
  for (const auto& p : pieces) cell[p.cell] += p.domain_area;
  for (double a : cell) EXPECT_NEAR(a, 0.25, 1e-12);
}

TEST(Domain, SeamRuleWithUnequalHemispheres) {
  // w_L = 1.5 (the left hemisphere has three times the right's area), K = 4: 8 columns of width
  // 0.25; centres 0.125 .. 1.875. Columns 0-5 (centres up to 1.375) are left, 6-7 right.
  const Domain d = Domain::rectangle(1.5);
  EXPECT_TRUE(d.has_seam());
  EXPECT_TRUE(d.same_part(4, 0, 5));
  EXPECT_FALSE(d.same_part(4, 5, 6));
  EXPECT_TRUE(d.same_part(4, 6, 7));
  EXPECT_EQ(d.part_of_x(1.49), 0);
  EXPECT_EQ(d.part_of_x(1.5), 1);
  // Equal areas: the seam between columns K-1 and K.
  EXPECT_FALSE(Domain::rectangle(1.0).same_part(4, 3, 4));
  EXPECT_TRUE(Domain::rectangle(1.0).same_part(4, 2, 3));
  // One cut-open surface, the square and the sphere have no seam.
  EXPECT_TRUE(Domain::rectangle(std::nan("")).same_part(4, 3, 4));
  EXPECT_TRUE(Domain::square().same_part(4, 0, 3));
  EXPECT_TRUE(Domain::sphere().same_part(4, 0, 7));
}

}  // namespace
}  // namespace authalic
