// The C API in a host process, as an engine uses it, through
// haha/haha_runtime.h only: 8 threads each with its own avatar reposing 1,000 times, 8
// threads sharing one avatar (each with its own haha_posed, as the header allows) and a
// shared motion, and 1,000 load/free cycles of the same file from a path and from memory
// with corrupt inputs interleaved. Every result is compared bit for bit with a reference
// computed once, serially; every error must land in the failing thread's haha_last_error
// and nowhere else. scripts/test-sanitize.sh runs it under ASan + LSan and under TSan.
//
// HAHA_STRESS_ITERATIONS (default 1000, the count) scales the loops down by hand;
// the sanitizer runs use the full count.
#include <gtest/gtest.h>
#include <malloc.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "format/avatar_pack.h"
#include "format/glb.h"
#include "haha/haha_runtime.h"
#include "io/npy.h"
#include "support/format_test_avatar.h"
#include "support/runtime_sample_inputs.h"

#if defined(__SANITIZE_THREAD__)
#define HAHA_STRESS_TSAN 1
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define HAHA_STRESS_TSAN 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__) || defined(HAHA_STRESS_TSAN)
#define HAHA_STRESS_SANITIZER_HEAP 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define HAHA_STRESS_SANITIZER_HEAP 1
#endif
#endif
#ifdef HAHA_STRESS_SANITIZER_HEAP
// The sanitizer runtime's (<sanitizer/allocator_interface.h>, which GCC does not ship).
extern "C" size_t __sanitizer_get_current_allocated_bytes(void);
#endif

namespace fs = std::filesystem;

namespace haha {
namespace {

constexpr int kThreads = 8;
constexpr int kPoses = 8;     // distinct poses the threads cycle through
constexpr int kImage = 24;    // rendered frames are kImage x kImage
constexpr int kRenderEvery = 100;

int iterations() {
  const char* s = std::getenv("HAHA_STRESS_ITERATIONS");
  const int n = s ? std::atoi(s) : 1000;
  return n > 0 ? n : 1000;
}

// Each worker thread sets its own OpenMP thread count (haha_set_num_threads is per thread),
// 1 or 2 by thread: results must not depend on it. Under TSan always 1: libgomp is not
// instrumented, so TSan cannot see its barriers and reports the writes of its pool threads
// as races with the caller's reads afterwards (false positives). With one OpenMP thread all
// haha code runs on the host threads TSan watches, so a real race between them still shows.
void set_openmp_threads(int t) {
#ifdef HAHA_STRESS_TSAN
  const int n = 1;
  (void)t;
#else
  const int n = 1 + t % 2;
#endif
  ASSERT_EQ(haha_set_num_threads(n), HAHA_OK);
}
void limit_openmp_under_tsan() {
#ifdef HAHA_STRESS_TSAN
  ASSERT_EQ(haha_set_num_threads(1), HAHA_OK);
#endif
}

// Heap bytes in use (all threads): the sanitizer's allocator, else glibc's arenas.
size_t heap_in_use() {
#ifdef HAHA_STRESS_SANITIZER_HEAP
  return __sanitizer_get_current_allocated_bytes();
#else
  return mallinfo2().uordblks;
#endif
}

// ---- fixtures -------------------------------------------------------------------------

struct OwnedDir {
  fs::path path = fs::temp_directory_path() / ("haha_runtime_stress_" + std::to_string(::getpid()));
  OwnedDir() { fs::create_directories(path); }
  ~OwnedDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

void write_bytes(const fs::path& p, const std::vector<uint8_t>& b) {
  std::ofstream f(p, std::ios::binary);
  f.write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size()));
}

using test::front_camera;
using test::random_pose;

// Avatars as an engine ships them: the default lossy pack (Draco mesh and Gaussians, JPEG
// texture, compact pose correctives). The reposed one has enough Gaussians that posing them
// is an OpenMP loop (core/parallel.h: kMinParallelItems); the one loaded 1,000 times is
// smaller (its load time is mostly the Draco decode).
constexpr int kGaussians = 4096, kSmallGaussians = 300;
struct Fixture {
  OwnedDir dir;
  std::vector<uint8_t> bytes, small, flipped, truncated;
  fs::path path, small_path, motion_path, missing_path;
  std::vector<std::array<float, 165>> poses;
  std::vector<std::array<float, 3>> translations;
  Fixture() {
    bytes = pack_avatar(test::make_test_avatar(kGaussians, 2, 32, 24), PackOptions{});
    path = dir.path / "avatar.glb";
    write_bytes(path, bytes);
    small = pack_avatar(test::make_test_avatar(kSmallGaussians, 3, 32, 24), PackOptions{});
    small_path = dir.path / "small.glb";
    write_bytes(small_path, small);
    missing_path = dir.path / "missing.glb";
    // Corrupt copies: one flipped byte in the Gaussian stream (its checksum catches it) and
    // the file cut in half.
    const glb::Glb g = glb::parse_glb(small.data(), small.size(), "fixture");
    const auto& bv =
        g.json["bufferViews"][g.json["extensions"]["HAHA_gaussian_avatar"]["gaussians"]["bufferView"].get<int>()];
    const size_t bin_start = 12 + 8 + g.json_chunk_bytes + 8;  // glb header, JSON chunk, BIN chunk header
    flipped = small;
    flipped[bin_start + bv["byteOffset"].get<size_t>() + bv["byteLength"].get<size_t>() / 2] ^= 0x10;
    truncated.assign(small.begin(), small.begin() + long(small.size() / 2));
    for (int k = 0; k < kPoses; ++k) {
      poses.push_back(random_pose(uint32_t(100 + k), 0.35f));
      translations.push_back({0.05f * float(k), -0.02f * float(k), 0.01f * float(k)});
    }
    // The same poses as a motion (AMASS layout, stored as is by haha_motion_load).
    std::vector<float> p, t;
    for (int k = 0; k < kPoses; ++k) {
      p.insert(p.end(), poses[size_t(k)].begin(), poses[size_t(k)].end());
      t.insert(t.end(), translations[size_t(k)].begin(), translations[size_t(k)].end());
    }
    Npz z;
    z.set("poses", NpyArray::from(p, {kPoses, 165}));
    z.set("trans", NpyArray::from(t, {kPoses, 3}));
    z.set("mocap_frame_rate", NpyArray::from(std::vector<double>{30.0}, {}));
    motion_path = dir.path / "motion.npz";
    z.write(motion_path.string());
  }
};
const Fixture& fx() {
  static const Fixture f;
  return f;
}

// Everything a repose gives back, and a frame rendered from it.
struct Frame {
  std::vector<float> verts, normals, joints, means, rotations, scales;
  std::vector<uint8_t> rgba;
  bool operator==(const Frame& o) const {
    return verts == o.verts && normals == o.normals && joints == o.joints && means == o.means &&
           rotations == o.rotations && scales == o.scales;
  }
};

// Collects a worker's failures (gtest assertions stay on the main thread).
struct Failures {
  int count = 0;
  std::string first;
  void add(const std::string& what) {
    if (count++ == 0) first = what;
  }
};

class Reader {
 public:
  explicit Reader(const haha_avatar* a) {
    haha_avatar_get_info(a, &info_);
    frame_.verts.resize(3 * size_t(info_.num_vertices));
    frame_.normals.resize(3 * size_t(info_.num_vertices));
    frame_.joints.resize(3 * HAHA_NUM_JOINTS);
    frame_.means.resize(3 * size_t(info_.num_gaussians));
    frame_.rotations.resize(4 * size_t(info_.num_gaussians));
    frame_.scales.resize(3 * size_t(info_.num_gaussians));
    frame_.rgba.resize(4 * size_t(kImage) * kImage);
  }
  // Reads the posed state back; false (with the failure noted) on any error.
  bool read(const haha_posed* p, Failures& f) {
    haha_gaussian_arrays g{};
    g.capacity = size_t(info_.num_gaussians);
    g.means = frame_.means.data(), g.rotations = frame_.rotations.data(), g.scales = frame_.scales.data();
    if (haha_posed_vertices(p, frame_.verts.data(), frame_.verts.size()) != HAHA_OK ||
        haha_posed_normals(p, frame_.normals.data(), frame_.normals.size()) != HAHA_OK ||
        haha_posed_joints(p, frame_.joints.data(), frame_.joints.size()) != HAHA_OK ||
        haha_posed_gaussians(p, &g) != HAHA_OK) {
      f.add(std::string("read back: ") + haha_last_error());
      return false;
    }
    return true;
  }
  bool render(haha_posed* p, Failures& f) {
    static const haha_camera cam = front_camera(kImage, kImage);
    const float bg[3] = {0.2f, 0.3f, 0.4f};
    if (haha_render(p, &cam, bg, 0, HAHA_PIXEL_RGBA8, frame_.rgba.data(), frame_.rgba.size()) != HAHA_OK) {
      f.add(std::string("haha_render: ") + haha_last_error());
      return false;
    }
    return true;
  }
  const Frame& frame() const { return frame_; }
  const haha_avatar_info& info() const { return info_; }

 private:
  haha_avatar_info info_{};
  Frame frame_;
};

bool all_finite(const std::vector<float>& v) {
  for (float x : v)
    if (!std::isfinite(x)) return false;
  return true;
}

// The reference: every pose reposed and rendered once, serially, from a fresh load.
struct Reference {
  std::vector<Frame> frames;  // per pose
  haha_avatar_info info{};
};
const Reference& reference() {
  static const Reference r = [] {
    Reference ref;
    haha_avatar* a = nullptr;
    haha_posed* p = nullptr;
    EXPECT_EQ(haha_avatar_load(fx().path.c_str(), nullptr, &a), HAHA_OK) << haha_last_error();
    EXPECT_EQ(haha_posed_create(a, &p), HAHA_OK) << haha_last_error();
    Reader reader(a);
    ref.info = reader.info();
    Failures f;
    for (int k = 0; k < kPoses; ++k) {
      EXPECT_EQ(haha_repose(p, fx().poses[size_t(k)].data(), fx().translations[size_t(k)].data(), nullptr, 0, nullptr, 0),
                HAHA_OK)
          << haha_last_error();
      reader.read(p, f);
      reader.render(p, f);
      ref.frames.push_back(reader.frame());
      const Frame& fr = ref.frames.back();
      for (const auto* v : {&fr.verts, &fr.normals, &fr.joints, &fr.means, &fr.rotations, &fr.scales})
        EXPECT_TRUE(all_finite(*v)) << "pose " << k;
    }
    EXPECT_EQ(f.count, 0) << f.first;
    haha_posed_free(p);
    haha_avatar_free(a);
    return ref;
  }();
  return r;
}

// One worker's frames: iteration i poses k = (3 i + t) % kPoses (threads out of step),
// checks the read-back against the reference bit for bit, renders every kRenderEvery-th
// frame, and every 97th iteration passes a non-finite pose: an argument error in this
// thread's haha_last_error that leaves the previous pose in place.
void repose_loop(haha_posed* p, Reader& reader, int t, int n, const haha_motion* motion, Failures& f) {
  const Reference& ref = reference();
  int last = -1;
  std::array<float, 165> pose{};
  std::array<float, 3> transl{};
  for (int i = 0; i < n; ++i) {
    const int k = (3 * i + t) % kPoses;
    if (motion) {
      if (haha_motion_frame(motion, k, pose.data(), transl.data()) != HAHA_OK) {
        f.add(std::string("haha_motion_frame: ") + haha_last_error());
        return;
      }
    } else {
      pose = fx().poses[size_t(k)];
      transl = fx().translations[size_t(k)];
    }
    if (i % 97 == 96 && last >= 0) {
      std::array<float, 165> bad = pose;
      bad[size_t(7 + t)] = NAN;
      if (haha_repose(p, bad.data(), transl.data(), nullptr, 0, nullptr, 0) != HAHA_ERROR_ARGUMENT) {
        f.add("a NaN pose was accepted");
        return;
      }
      const std::string want = "haha_repose: pose[" + std::to_string(7 + t) + "] is not finite";
      if (haha_last_error() != want) f.add("thread " + std::to_string(t) + " error: '" + haha_last_error() + "'");
      if (!reader.read(p, f)) return;
      if (haha_last_error()[0] != '\0') f.add("last error not cleared by a successful call");
      if (!(reader.frame() == ref.frames[size_t(last)])) f.add("an argument error changed the pose");
    }
    if (haha_repose(p, pose.data(), transl.data(), nullptr, 0, nullptr, 0) != HAHA_OK) {
      f.add(std::string("haha_repose: ") + haha_last_error());
      return;
    }
    last = k;
    if (!reader.read(p, f)) return;
    if (!(reader.frame() == ref.frames[size_t(k)]))
      f.add("thread " + std::to_string(t) + " iteration " + std::to_string(i) + ": pose " + std::to_string(k) +
            " differs from the reference");
    if (i % kRenderEvery == kRenderEvery - 1) {
      if (!reader.render(p, f)) return;
      if (reader.frame().rgba != ref.frames[size_t(k)].rgba)
        f.add("thread " + std::to_string(t) + " iteration " + std::to_string(i) + ": render of pose " +
              std::to_string(k) + " differs from the reference");
    }
  }
}

// ---- 8 threads, each with its own avatar ----------------------------------------------

TEST(RuntimeStress, EightThreadsEachWithItsOwnAvatarRepose1000Times) {
  limit_openmp_under_tsan();
  (void)reference();
  const int n = iterations();
  std::vector<Failures> failures(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      set_openmp_threads(t);
      Failures& f = failures[size_t(t)];
      haha_avatar* a = nullptr;
      haha_posed* p = nullptr;
      if (haha_avatar_load(fx().path.c_str(), nullptr, &a) != HAHA_OK || haha_posed_create(a, &p) != HAHA_OK) {
        f.add(std::string("load: ") + haha_last_error());
      } else {
        Reader reader(a);
        repose_loop(p, reader, t, n, nullptr, f);
      }
      haha_posed_free(p);
      haha_avatar_free(a);
    });
  }
  for (auto& th : threads) th.join();
  for (int t = 0; t < kThreads; ++t) EXPECT_EQ(failures[size_t(t)].count, 0) << "thread " << t << ": " << failures[size_t(t)].first;
}

// ---- 8 threads sharing one avatar and one motion --------------------------------------

// The header: haha_avatar and haha_motion may be used by any number of threads at once
// (getters, haha_posed_create, haha_motion_frame, haha_motion_load_for_avatar); each
// haha_posed by one thread at a time.
TEST(RuntimeStress, EightThreadsShareOneAvatarEachWithItsOwnPoseState) {
  limit_openmp_under_tsan();
  const Reference& ref = reference();
  const int n = iterations();
  haha_avatar* shared = nullptr;
  haha_motion* motion = nullptr;
  ASSERT_EQ(haha_avatar_load_memory(fx().bytes.data(), fx().bytes.size(), "shared.glb", nullptr, &shared), HAHA_OK)
      << haha_last_error();
  ASSERT_EQ(haha_motion_load(fx().motion_path.c_str(), &motion), HAHA_OK) << haha_last_error();
  // Pose-independent data, read once here and by every thread while the others repose.
  const size_t F = size_t(ref.info.num_faces), T = 3 * size_t(ref.info.texture_width) * size_t(ref.info.texture_height);
  std::vector<uint32_t> faces(3 * F);
  std::vector<float> uvs(6 * F);
  std::vector<uint8_t> texture(T);
  ASSERT_EQ(haha_avatar_faces(shared, faces.data(), faces.size()), HAHA_OK);
  ASSERT_EQ(haha_avatar_face_uvs(shared, uvs.data(), uvs.size()), HAHA_OK);
  ASSERT_EQ(haha_avatar_texture(shared, texture.data(), texture.size()), HAHA_OK);

  std::vector<Failures> failures(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      set_openmp_threads(t);
      Failures& f = failures[size_t(t)];
      haha_posed* p = nullptr;
      if (haha_posed_create(shared, &p) != HAHA_OK) {
        f.add(std::string("haha_posed_create: ") + haha_last_error());
        return;
      }
      Reader reader(shared);
      // Chunks of reposes (poses from the shared motion's frames), each followed by reads of
      // the avatar's pose-independent data and a motion loaded for it, while the other
      // threads repose.
      const int chunk = 100;
      for (int done = 0; done < n && f.count == 0; done += chunk) {
        repose_loop(p, reader, t, std::min(chunk, n - done), motion, f);
        haha_avatar_info info{};
        std::vector<uint32_t> my_faces(faces.size());
        std::vector<float> my_uvs(uvs.size());
        std::vector<uint8_t> my_texture(texture.size());
        if (haha_avatar_get_info(shared, &info) != HAHA_OK || info.num_gaussians != ref.info.num_gaussians ||
            haha_avatar_faces(shared, my_faces.data(), my_faces.size()) != HAHA_OK || my_faces != faces ||
            haha_avatar_face_uvs(shared, my_uvs.data(), my_uvs.size()) != HAHA_OK || my_uvs != uvs ||
            haha_avatar_texture(shared, my_texture.data(), my_texture.size()) != HAHA_OK || my_texture != texture)
          f.add(std::string("shared avatar data differs: ") + haha_last_error());
        haha_motion* m = nullptr;
        int32_t frames = 0;
        if (haha_motion_load_for_avatar(fx().motion_path.c_str(), shared, &m) != HAHA_OK ||
            haha_motion_info(m, &frames, nullptr) != HAHA_OK || frames != kPoses)
          f.add(std::string("haha_motion_load_for_avatar: ") + haha_last_error());
        haha_motion_free(m);
      }
      haha_posed_free(p);
    });
  }
  for (auto& th : threads) th.join();
  for (int t = 0; t < kThreads; ++t) EXPECT_EQ(failures[size_t(t)].count, 0) << "thread " << t << ": " << failures[size_t(t)].first;
  haha_motion_free(motion);
  haha_avatar_free(shared);
}

// ---- 1,000 load/free cycles -----------------------------------------------------------

// One cycle: the small avatar loaded (from its path on even cycles, from a copy of its bytes
// freed as soon as the call returns on odd ones), posed once and freed; every 10th cycle of
// a thread the corrupt inputs too (flipped byte, truncated, missing file), each error naming
// this thread's input in this thread's haha_last_error.
void load_cycle(int t, int i, Failures& f) {
  const std::string tag = "t" + std::to_string(t);
  auto expect_ok = [&](haha_status s, const char* what) {
    if (s != HAHA_OK) f.add(std::string(what) + ": " + haha_last_error());
    else if (haha_last_error()[0] != '\0') f.add(std::string(what) + ": last error not cleared");
  };
  auto expect_error = [&](haha_status s, haha_status want, const std::string& prefix, const char* needle) {
    const std::string msg = haha_last_error();
    if (s != want || msg.rfind(prefix + ": ", 0) != 0 || msg.find(needle) == std::string::npos)
      f.add(tag + ": got " + haha_status_string(s) + " '" + msg + "', want " + haha_status_string(want) + " '" + prefix +
            ": ..." + needle + "...'");
  };
  haha_avatar* a = nullptr;
  if (i % 2 == 0) {
    expect_ok(haha_avatar_load(fx().small_path.c_str(), nullptr, &a), "haha_avatar_load");
  } else {
    auto* copy = new std::vector<uint8_t>(fx().small);
    expect_ok(haha_avatar_load_memory(copy->data(), copy->size(), tag.c_str(), nullptr, &a), "haha_avatar_load_memory");
    delete copy;  // the avatar must not need the bytes any more
  }
  haha_avatar_info info{};
  expect_ok(haha_avatar_get_info(a, &info), "haha_avatar_get_info");
  if (info.num_gaussians != kSmallGaussians) f.add("wrong Gaussian count");
  haha_posed* p = nullptr;
  expect_ok(haha_posed_create(a, &p), "haha_posed_create");
  expect_ok(haha_repose(p, fx().poses[size_t(i % kPoses)].data(), nullptr, nullptr, 0, nullptr, 0), "haha_repose");
  haha_posed_free(p);
  haha_avatar_free(a);

  if ((i + t) % 10 == 9) {  // threads out of step
    haha_avatar* none = nullptr;
    const std::string flipped_name = tag + "_flipped.glb", cut_name = tag + "_cut.glb";
    expect_error(haha_avatar_load_memory(fx().flipped.data(), fx().flipped.size(), flipped_name.c_str(), nullptr, &none),
                 HAHA_ERROR_FORMAT, flipped_name, "gaussians: checksum mismatch");
    expect_error(haha_avatar_load_memory(fx().truncated.data(), fx().truncated.size(), cut_name.c_str(), nullptr, &none),
                 HAHA_ERROR_FORMAT, cut_name, "");
    expect_error(haha_avatar_load(fx().missing_path.c_str(), nullptr, &none), HAHA_ERROR_IO, fx().missing_path.string(),
                 "cannot open");
    if (none != nullptr) f.add("a failed load wrote its output");
  }
}

TEST(RuntimeStress, LoadAndFreeTheSameFile1000TimesWithCorruptInputsInterleaved) {
  limit_openmp_under_tsan();
  const int n = iterations();
  // The cycles run on 8 threads at once, each with its own errors, and the heap is
  // measured around them: a leak of even a few bytes per cycle shows (LSan says where under
  // ASan; this catches it in the normal build too). A first round warms up what is
  // allocated once (per-thread and first-use allocations of the libraries).
  std::vector<Failures> failures(kThreads);
  auto round = [&](int cycles, int first) {
    std::vector<std::thread> threads;
    for (int t = 0; t < kThreads; ++t) {
      threads.emplace_back([&, t] {
        set_openmp_threads(t);
        for (int i = 0; i < cycles && failures[size_t(t)].count == 0; ++i)
          load_cycle(t, first + i, failures[size_t(t)]);
      });
    }
    for (auto& th : threads) th.join();
  };
  round(2, 0);
  const size_t before = heap_in_use();
  const int per_thread = (n + kThreads - 1) / kThreads;  // 125 x 8 = 1000
  round(per_thread, 2);
  const size_t after = heap_in_use();
  for (int t = 0; t < kThreads; ++t) EXPECT_EQ(failures[size_t(t)].count, 0) << "thread " << t << ": " << failures[size_t(t)].first;
  EXPECT_LE(after, before + 64 * 1024) << "heap grew by " << (after - before) << " bytes over " << per_thread * kThreads
                                       << " cycles";
  std::printf("heap in use: %zu bytes before, %zu after %d load/free cycles\n", before, after, per_thread * kThreads);
}

}  // namespace
}  // namespace haha
