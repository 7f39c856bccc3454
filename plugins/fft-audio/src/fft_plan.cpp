// SPDX-License-Identifier: Apache-2.0
#include "fft_plan.h"

#include <fftw3.h>

#include <mutex>
#include <stdexcept>
#include <utility>

namespace skr::audio {
namespace {
std::mutex& plannerMutex() {
  static std::mutex m;
  return m;
}
int g_live_plans = 0;  // guarded by plannerMutex()
}  // namespace

FftPlan::FftPlan(std::size_t size) : size_(size) {
  std::lock_guard lock(plannerMutex());
  in_ = fftw_alloc_real(size);
  out_ = fftw_alloc_complex(size / 2 + 1);
  if (in_ != nullptr && out_ != nullptr) {
    // FFTW_ESTIMATE: no measuring at start-up (it would take seconds and overwrite buffers).
    plan_ = fftw_plan_dft_r2c_1d(static_cast<int>(size), in_, static_cast<fftw_complex*>(out_),
                                 FFTW_ESTIMATE);
  }
  if (plan_ != nullptr) ++g_live_plans;
  if (plan_ == nullptr) {
    fftw_free(in_);
    fftw_free(out_);
    throw std::runtime_error("FFTW could not plan a transform of size " + std::to_string(size));
  }
}

FftPlan::~FftPlan() {
  release();
}

FftPlan::FftPlan(FftPlan&& other) noexcept
    : size_(std::exchange(other.size_, 0)),
      in_(std::exchange(other.in_, nullptr)),
      out_(std::exchange(other.out_, nullptr)),
      plan_(std::exchange(other.plan_, nullptr)) {}

FftPlan& FftPlan::operator=(FftPlan&& other) noexcept {
  if (this != &other) {
    release();
    size_ = std::exchange(other.size_, 0);
    in_ = std::exchange(other.in_, nullptr);
    out_ = std::exchange(other.out_, nullptr);
    plan_ = std::exchange(other.plan_, nullptr);
  }
  return *this;
}

void FftPlan::release() noexcept {
  if (plan_ == nullptr && in_ == nullptr && out_ == nullptr) return;
  std::lock_guard lock(plannerMutex());
  fftw_free(in_);
  fftw_free(out_);
  if (plan_ != nullptr) {
    fftw_destroy_plan(static_cast<fftw_plan>(plan_));
    // The planner keeps tables (~120 KB) until fftw_cleanup(); without it they would be lost when
    // the module and libfftw3 are unloaded. fft-audio is the only FFTW user in the hub: anyone
    // adding another must share this counter (fftw_cleanup invalidates every plan).
    if (--g_live_plans == 0) fftw_cleanup();
  }
  plan_ = nullptr;
  in_ = nullptr;
  out_ = nullptr;
}

const std::complex<double>* FftPlan::output() const noexcept {
  // fftw_complex is double[2], layout-compatible with std::complex<double> (FFTW manual 4.1.1).
  return static_cast<const std::complex<double>*>(out_);
}

void FftPlan::execute() noexcept {
  fftw_execute(static_cast<fftw_plan>(plan_));
}

}  // namespace skr::audio
