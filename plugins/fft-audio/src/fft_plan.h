// SPDX-License-Identifier: Apache-2.0
// An FFTW real-to-complex plan with its aligned buffers, made once and reused (RAII).
// Plan creation and destruction are not thread-safe in FFTW: a process-wide mutex guards them.
// When the last plan goes, the planner's tables are freed (fftw_cleanup).
// execute() may run on any one thread at a time.
#pragma once

#include <complex>
#include <cstddef>

namespace skr::audio {

class FftPlan {
 public:
  explicit FftPlan(std::size_t size);  // throws std::runtime_error when FFTW refuses
  ~FftPlan();
  FftPlan(const FftPlan&) = delete;
  FftPlan& operator=(const FftPlan&) = delete;
  FftPlan(FftPlan&& other) noexcept;
  FftPlan& operator=(FftPlan&& other) noexcept;

  [[nodiscard]] std::size_t size() const noexcept { return size_; }
  [[nodiscard]] double* input() noexcept { return in_; }  // size() values
  // size()/2 + 1 bins, valid after execute().
  [[nodiscard]] const std::complex<double>* output() const noexcept;
  void execute() noexcept;

 private:
  void release() noexcept;
  std::size_t size_ = 0;
  double* in_ = nullptr;
  void* out_ = nullptr;   // fftw_complex[size/2 + 1]
  void* plan_ = nullptr;  // fftw_plan
};

}  // namespace skr::audio
