// Placing a motion file's poses on the synthetic subject (`haha synth --motion`): the camera
// of the synth frames is static, so a motion that travels (an AMASS walk covers metres) is
// held in place horizontally and stood on the subject's floor (synth_subject.h).
#include <algorithm>
#include <string>

#include "core/error.h"
#include "core/parallel.h"
#include "synth/synth_subject.h"

namespace haha {

std::vector<SmplxParams> place_synth_motion(const BodyModel& body, const SynthSubject& subject,
                                            std::vector<SmplxParams> frames) {
  if (subject.rest_verts.size() != size_t(body.num_verts) * 3) fail("synth motion", "subject built for another body");
  const size_t num_expr = size_t(std::min(10, body.num_expr));
  for (SmplxParams& p : frames) {
    p.betas = subject.betas;
    p.expression.resize(num_expr, 0.0f);
    p.transl[0] = p.transl[2] = 0;
  }
  // One vertical shift for the whole motion, not one per frame: a jump stays a jump.
  const Lbs<float> lbs(body);
  std::vector<std::vector<float>> scratch(size_t(std::max(1, num_threads())),
                                          std::vector<float>(size_t(body.num_verts) * 3));
  std::vector<double> lowest(frames.size(), 1e30);
  parallel_for_dynamic(int64_t(frames.size()), [&](int64_t i) {
    std::vector<float>& v = scratch[size_t(thread_index())];
    lbs.forward(frames[size_t(i)], v.data(), nullptr, nullptr);
    for (size_t k = 1; k < v.size(); k += 3) lowest[size_t(i)] = std::min(lowest[size_t(i)], double(v[k]));
  });
  double floor_y = 1e30, lo = 1e30;
  for (size_t i = 1; i < subject.rest_verts.size(); i += 3) floor_y = std::min(floor_y, double(subject.rest_verts[i]));
  for (double l : lowest) lo = std::min(lo, l);
  const float shift = float(floor_y - lo);
  for (SmplxParams& p : frames) p.transl[1] += shift;
  return frames;
}

}  // namespace haha
