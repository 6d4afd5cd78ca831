// The measurements behind `haha bench` (speed and size against error), on one trained run:
//
//   1 filtering   Gaussian budget against error: stage 3 re-run from the run's stage-2
//                 checkpoint with several opacity-regulariser weights, and pruning of the
//                 trained opacities at several thresholds -> Gaussian count, storage, PSNR /
//                 SSIM on the test split (novel poses), render time.
//   2 packing     quantization bits and texture codec / size -> bytes, PSNR of the unpacked
//                 avatar's renders against the original's, decode time.
//   3 render      render time against resolution and Gaussian count, per CPU thread count
//                 (and on the GPU through a caller-supplied timer).
//   4 training    the trainer's stage table (mesh only / full Gaussians / naive merge /
//                 HAHA) against the wall time each needed to train.
//
// No file I/O here beyond /proc/cpuinfo: app/bench_run.h loads the run and
// bench/bench_report.h writes bench.json, bench.md and the plots.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "body/avatar.h"
#include "format/avatar_pack.h"
#include "train/config.h"
#include "train/evaluate.h"
#include "train/trainer.h"

namespace haha {

// ---- the machine ------------------------------------------------------------------------
struct MachineInfo {
  std::string cpu_model;  // /proc/cpuinfo "model name" ("unknown CPU" when absent)
  int logical_cpus = 0;   // processors listed there (or std::thread's count)
  int threads = 0;        // OpenMP threads this process uses by default
  std::string gpu;        // the CUDA device used, empty when none
  double load_average = -1;  // 1-minute load average when measured (/proc/loadavg), -1 unknown
  std::string omp_wait_policy;  // OMP_WAIT_POLICY as set ("" = the runtime's default)
  std::string line() const;  // "AMD EPYC, 2 logical CPUs" (+ ", GPU ...")
};
MachineInfo machine_info();

// ---- shared evaluation --------------------------------------------------------------------
// The frames every quality number is measured on (normally the test split at the run's
// training resolution) and how (test-time pose optimisation, background).
struct BenchEval {
  std::vector<TrainFrame> frames;
  EvalOptions options;
};

struct QualityPoint {
  int gaussians = 0;
  int64_t storage_bytes = 0;  // train/evaluate.h storage_bytes (paper's float32 accounting)
  double psnr = 0, ssim = 0;  // means over the frames, dB / [-1, 1]
  double render_ms = 0;       // mean LBS + render time per frame (threads as set)
};

// The avatar rendered with both layers (HAHA), or one of them, on the bench frames.
QualityPoint evaluate_quality(const Avatar& a, const BenchEval& ev, bool mesh = true, bool gaussians = true);

// ---- 1 filtering ------------------------------------------------------------------------
struct FilterPoint {
  std::string method;     // "opacity weight" / "image cost" (stage 3 re-run) or "prune threshold" (post hoc)
  double strength = 0;    // the weight / the image cost / the threshold
  QualityPoint q;
  double stage3_seconds = 0;  // wall time of the re-run stage 3 (0 for post-hoc pruning)
};

// The avatar without the Gaussians whose opacity is below `threshold` (order kept).
Avatar prune_by_opacity(const Avatar& a, double threshold);

std::vector<FilterPoint> sweep_prune_thresholds(const Avatar& trained, const std::vector<double>& thresholds,
                                                const BenchEval& ev);

// Stage 3 again from the end of stage 2, as the run trained it.
struct RetrainSetup {
  TrainConfig config;           // the run's resolved config
  TrainInput input;             // the run's training frames and body
  TrainCheckpoint stage2;       // RUN/checkpoint_stage2.npz
  std::string checkpoint_path;  // named in errors
};

// What a stage-3 re-run changes: the opacity weight (s3.w.opacity) or, for a run that filters
// by the image instead (s3.prune_cost > 0, no opacity weight: estimated fits), the image cost.
enum class Stage3Knob { opacity_weight, image_cost };
const char* stage3_knob_method(Stage3Knob k);  // FilterPoint::method of its points

// One re-run of stage 3 per value of the knob (the config's other settings kept).
// Throws haha::Error (checkpoint path) when the checkpoint is not at the start of stage 3.
std::vector<FilterPoint> sweep_stage3(const RetrainSetup& setup, Stage3Knob knob, const std::vector<double>& values,
                                      const BenchEval& ev, const std::function<void(const std::string&)>& log);

// ---- 2 packing --------------------------------------------------------------------------
struct PackSetting {
  std::string name;          // shown in tables and plots
  std::string group;         // "gaussian bits", "texture", "reference"
  bool lossless = false;     // float32 everywhere (the bit-exact reference)
  int gaussian_bits = -1;    // every Gaussian attribute; -1 = the format's defaults
  std::string gaussian_bits_spec;  // per attribute ("offset=10,rotation=6"); overrides gaussian_bits
  std::string mesh_bits_spec;      // mesh Draco bits ("position=14,weight=8"); "" = the format's defaults
  bool plain_mesh = false;   // --mesh-compression none: plain accessors, no required extension
  std::string texture_codec = "jpg";  // png | jpg | webp
  int texture_quality = PackOptions{}.texture_quality;
  int texture_size = 0;      // 0 = the trained size
  // Pose correctives: "" = the format's default (compact, default codec), "none", "dense",
  // or a compact codec "t=0.05,r=2,b=8" (format/pose_correctives_codec.h).
  std::string pose_correctives;
};

struct PackedBytes {
  size_t total = 0, gaussians = 0, texture = 0, mesh = 0, pose_correctives = 0;
};

// The avatar packed in memory with a setting (format/avatar_pack.h); sizes per part.
std::vector<uint8_t> pack_with_setting(const Avatar& a, const PackSetting& s, PackedBytes& bytes);

struct PackPoint {
  PackSetting setting;
  PackedBytes bytes;
  double pack_ms = 0;    // one run
  double decode_ms = 0;  // fastest of three runs
  // Renders of the unpacked avatar against the original avatar's renders on the same
  // poses (pooled MSE over all frames). Identical renders: `identical` and kPsnrCap.
  double psnr_vs_original = 0;
  bool identical = false;
  double psnr = 0, ssim = 0;  // against the ground truth
  double psnr_cost = 0;       // PSNR(original vs truth) - PSNR(unpacked vs truth), dB
};
inline constexpr double kPsnrCap = 100.0;

// Lossless reference; all Gaussian attributes at 4..16 bits (texture png, so only the
// Gaussians' quantization differs); the texture as png, jpg and webp at quality 95 and 75
// at the trained size, and in the format's default codec / quality at halved sizes down to
// 1/8 (>= 32 px), with the Gaussians at the format's default bits. The setting equal to the
// format's defaults (default_codec, default_quality, trained size) is named "(default)".
// default_codec / default_quality empty / 0: the format's defaults (format/avatar_pack.h).
std::vector<PackSetting> default_pack_settings(int trained_texture_size, std::string default_codec = "",
                                               int default_quality = 0);

// The unpacked avatar is rendered the way `haha render --model` does: when the file carries
// no pose correctives, the original body's are used (but not for the setting
// pose_correctives "none": a loader without the body model); embedded ones (the default)
// are measured with the rest.
std::vector<PackPoint> sweep_packing(const Avatar& original, const std::vector<PackSetting>& settings,
                                     const BenchEval& ev,
                                     const std::function<void(const std::string&)>& log);

// ---- 3 render speed ---------------------------------------------------------------------
struct RenderTiming {
  std::string sweep;           // "resolution" or "gaussians"
  std::string device = "cpu";  // "cpu" or "cuda"
  int threads = 0;             // CPU threads (0 on the GPU)
  int resolution = 0;          // image side, pixels
  int gaussians = 0;
  bool mesh = true;
  double ms_median = 0, ms_min = 0;  // LBS + render of one frame
  int repeats = 0;
};

// GPU time of one frame of the avatar at the camera and pose: LBS + the merged render on
// the device (cuda/avatar_render_cuda.h), the avatar's buffers uploaded once beforehand;
// median of `repeats` after a warm-up, each ending with a device synchronisation. Throws
// haha::Error when this build has no CUDA backend.
double gpu_render_ms(const Avatar& a, const Camera& cam, const SmplxParams& pose, int repeats);

struct RenderSweepOptions {
  std::vector<int> resolutions{128, 256, 512, 1024};
  std::vector<int> threads{1, 2};
  std::vector<double> gaussian_fractions{0.125, 0.25, 0.5, 1.0};  // of the full (stage-1) avatar
  int count_resolution = 512;   // image side of the Gaussian-count sweep
  int repeats = 5;              // per point (fewer when one frame takes over a second)
  bool gpu = false;              // also time the GPU (gpu_render_ms)
};

// A camera like `cam` with its longer side scaled to `side` pixels.
Camera scaled_camera(const Camera& cam, int side);

// Every n-th Gaussian, so that about fraction * N are kept (spread over the whole body).
Avatar subsample_gaussians(const Avatar& a, double fraction);

// Resolution sweep on the filtered avatar (and mesh only); Gaussian-count sweep on subsets
// of the full avatar plus the filtered one, at count_resolution. Pose and view: `frame`.
std::vector<RenderTiming> sweep_render_speed(const Avatar& filtered, const Avatar& full, const TrainFrame& frame,
                                             const RenderSweepOptions& opt,
                                             const std::function<void(const std::string&)>& log);

// ---- 4 training -------------------------------------------------------------------------
struct StageRow {
  std::string name;      // mesh only, full Gaussians, naive merge, HAHA filtered
  QualityPoint q;
  double train_seconds = 0;  // as the paper's table attributes it (train/evaluate.h)
};

std::vector<StageRow> stage_table(const Avatar& filtered, const Avatar& stage1, const std::array<double, 3>& stage_seconds,
                                  const BenchEval& ev);

}  // namespace haha
