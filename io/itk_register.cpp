// Rigid PET-to-T1 registration with ITK's v4 framework (Mattes mutual information, regular-step
// gradient descent, 3 levels). Volumes arrive in memory (io/registration.cpp): ITK's NIfTI reader
// is not linked (symbol clash with nifti-clib). ITK works in LPS; our affines are RAS.
#include "io/itk_register.h"

#include <itkCenteredTransformInitializer.h>
#include <itkEuler3DTransform.h>
#include <itkImage.h>
#include <itkImageRegistrationMethodv4.h>
#include <itkMattesMutualInformationImageToImageMetricv4.h>
#include <itkRegistrationParameterScalesFromPhysicalShift.h>
#include <itkRegularStepGradientDescentOptimizerv4.h>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace authalic::io::detail {
namespace {

using ImageType = itk::Image<float, 3>;

ImageType::Pointer to_itk(const PlainVolume& v) {
  auto img = ImageType::New();
  ImageType::SizeType size;
  for (int d = 0; d < 3; ++d) size[d] = static_cast<itk::SizeValueType>(v.dims[d]);
  img->SetRegions(ImageType::RegionType(size));
  img->Allocate();
  std::copy(v.data->begin(), v.data->end(), img->GetBufferPointer());
  // LPS = diag(-1, -1, 1) RAS.
  ImageType::SpacingType spacing;
  ImageType::DirectionType direction;
  ImageType::PointType origin;
  for (int c = 0; c < 3; ++c) {
    double norm = 0;
    for (int r = 0; r < 3; ++r) norm += v.vox2ras[4 * r + c] * v.vox2ras[4 * r + c];
    spacing[c] = std::sqrt(norm);
    for (int r = 0; r < 3; ++r) direction(r, c) = (r < 2 ? -1.0 : 1.0) * v.vox2ras[4 * r + c] / spacing[c];
  }
  for (int r = 0; r < 3; ++r) origin[r] = (r < 2 ? -1.0 : 1.0) * v.vox2ras[4 * r + 3];
  img->SetSpacing(spacing);
  img->SetDirection(direction);
  img->SetOrigin(origin);
  return img;
}

}  // namespace

PlainRigidResult itk_register_rigid(const PlainVolume& fixed_in, const PlainVolume& moving_in) {
  using Transform = itk::Euler3DTransform<double>;
  using Optimizer = itk::RegularStepGradientDescentOptimizerv4<double>;
  using Metric = itk::MattesMutualInformationImageToImageMetricv4<ImageType, ImageType>;
  using Registration = itk::ImageRegistrationMethodv4<ImageType, ImageType, Transform>;
  const ImageType::Pointer fixed = to_itk(fixed_in), moving = to_itk(moving_in);

  auto transform = Transform::New();
  using Initializer = itk::CenteredTransformInitializer<Transform, ImageType, ImageType>;
  auto init = Initializer::New();
  init->SetTransform(transform);
  init->SetFixedImage(fixed);
  init->SetMovingImage(moving);
  init->MomentsOn();  // centres of mass: PET and T1 overlap roughly, their grids may not
  init->InitializeTransform();

  auto metric = Metric::New();
  metric->SetNumberOfHistogramBins(50);
  metric->SetMaximumNumberOfWorkUnits(1);  // one work unit: the same sums, so the same result, for any thread count
  auto optimizer = Optimizer::New();
  optimizer->SetLearningRate(2.0);
  optimizer->SetMinimumStepLength(1e-3);
  optimizer->SetRelaxationFactor(0.5);
  optimizer->SetNumberOfIterations(200);
  optimizer->SetGradientMagnitudeTolerance(1e-6);
  using Scales = itk::RegistrationParameterScalesFromPhysicalShift<Metric>;
  auto scales = Scales::New();
  scales->SetMetric(metric);
  optimizer->SetScalesEstimator(scales);
  optimizer->SetNumberOfWorkUnits(1);

  auto registration = Registration::New();
  registration->SetFixedImage(fixed);
  registration->SetMovingImage(moving);
  registration->SetMetric(metric);
  registration->SetOptimizer(optimizer);
  registration->SetInitialTransform(transform);
  registration->InPlaceOn();
  registration->SetNumberOfWorkUnits(1);
  registration->SetNumberOfLevels(3);
  Registration::ShrinkFactorsArrayType shrink(3);
  shrink[0] = 4;
  shrink[1] = 2;
  shrink[2] = 1;
  Registration::SmoothingSigmasArrayType sigmas(3);
  sigmas[0] = 4.0;
  sigmas[1] = 2.0;
  sigmas[2] = 0.0;
  registration->SetShrinkFactorsPerLevel(shrink);
  registration->SetSmoothingSigmasPerLevel(sigmas);
  registration->SetSmoothingSigmasAreSpecifiedInPhysicalUnits(true);
  registration->SetMetricSamplingStrategy(Registration::MetricSamplingStrategyEnum::REGULAR);
  registration->SetMetricSamplingPercentage(0.25);
  registration->MetricSamplingReinitializeSeed(20261123);  // fixed seed: deterministic
  try {
    registration->Update();
  } catch (const itk::ExceptionObject& e) {
    throw std::runtime_error(std::string("rigid registration failed: ") + e.GetDescription());
  }

  // ITK's transform maps fixed physical points to moving ones (LPS): y = M x + o.
  // In RAS: y_ras = S (M (S x_ras) + o) with S = diag(-1, -1, 1).
  const auto M = transform->GetMatrix();
  const auto o = transform->GetOffset();
  PlainRigidResult r;
  const double s[3] = {-1, -1, 1};
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) r.fixed_to_moving_ras[4 * i + j] = s[i] * M(i, j) * s[j];
    r.fixed_to_moving_ras[4 * i + 3] = s[i] * o[i];
  }
  r.fixed_to_moving_ras[15] = 1.0;
  r.metric = optimizer->GetValue();
  r.iterations = static_cast<int>(optimizer->GetCurrentIteration());
  r.stop_condition = optimizer->GetStopConditionDescription();
  return r;
}

}  // namespace authalic::io::detail
