// The synthetic subject on the low-resolution body with a 256-px atlas, built once per test
// program: what the synth layer's tests render and pose.
#pragma once

#include "support/low_body.h"
#include "synth/synth_subject.h"

namespace haha::test {

inline const SynthSubject& low_subject() {
  static const SynthSubject s = [] {
    SynthSubjectOptions o;
    o.texture_size = 256;
    return make_synth_subject(low_body(), o);
  }();
  return s;
}

}  // namespace haha::test
