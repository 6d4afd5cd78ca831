// A built-in 5 x 7 bitmap font (ASCII letters, digits and common punctuation; lower case is
// drawn as upper case, anything else as '?'): contact-sheet labels and the synthetic
// subject's lettering, with no font file or library.
#pragma once

#include <string>

#include "core/image.h"

namespace haha {

constexpr int kFontWidth = 5, kFontHeight = 7;
constexpr int kFontAdvance = kFontWidth + 1;  // one blank column between characters

// Whether pixel (x, y) of character c's glyph is set; x in [0, 5), y in [0, 7) from the
// top. Outside that box: false.
bool font_pixel(char c, int x, int y);

// Width in pixels of `text` drawn at `scale` (no trailing gap): advance * n - scale.
int text_width(const std::string& text, int scale = 1);

// Draws `text` with its top-left corner at (x, y), each font pixel a scale x scale block of
// colour rgb (1-channel images get the mean of rgb; a 4th channel is set to 1). Clipped to
// the image.
void draw_text(Image& img, int x, int y, const std::string& text, const float rgb[3], int scale = 1);

}  // namespace haha
