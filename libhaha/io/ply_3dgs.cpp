#include "io/ply_3dgs.h"

#include <bit>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/math.h"
#include "render/sh.h"

namespace haha {
namespace {

enum class PlyType { i8, u8, i16, u16, i32, u32, f32, f64 };

bool parse_type(const std::string& s, PlyType& t) {
  static const std::map<std::string, PlyType> types = {
      {"char", PlyType::i8},    {"int8", PlyType::i8},     {"uchar", PlyType::u8},    {"uint8", PlyType::u8},
      {"short", PlyType::i16},  {"int16", PlyType::i16},   {"ushort", PlyType::u16},  {"uint16", PlyType::u16},
      {"int", PlyType::i32},    {"int32", PlyType::i32},   {"uint", PlyType::u32},    {"uint32", PlyType::u32},
      {"float", PlyType::f32},  {"float32", PlyType::f32}, {"double", PlyType::f64}, {"float64", PlyType::f64}};
  const auto it = types.find(s);
  if (it == types.end()) return false;
  t = it->second;
  return true;
}

int type_size(PlyType t) {
  switch (t) {
    case PlyType::i8: case PlyType::u8: return 1;
    case PlyType::i16: case PlyType::u16: return 2;
    case PlyType::i32: case PlyType::u32: case PlyType::f32: return 4;
    case PlyType::f64: return 8;
  }
  return 0;
}

template <class U>
U load(const uint8_t* p, bool swap) {
  uint8_t b[sizeof(U)];
  std::memcpy(b, p, sizeof(U));
  if (swap)
    for (size_t i = 0; i < sizeof(U) / 2; ++i) std::swap(b[i], b[sizeof(U) - 1 - i]);
  U v;
  std::memcpy(&v, b, sizeof(U));
  return v;
}

double load_value(const uint8_t* p, PlyType t, bool swap) {
  switch (t) {
    case PlyType::i8: return double(int8_t(p[0]));
    case PlyType::u8: return double(p[0]);
    case PlyType::i16: return double(load<int16_t>(p, swap));
    case PlyType::u16: return double(load<uint16_t>(p, swap));
    case PlyType::i32: return double(load<int32_t>(p, swap));
    case PlyType::u32: return double(load<uint32_t>(p, swap));
    case PlyType::f32: return double(load<float>(p, swap));
    case PlyType::f64: return load<double>(p, swap);
  }
  return 0;
}

struct Property {
  std::string name;
  PlyType type;
  int offset;  // bytes into a binary record
};

struct Header {
  enum Format { ascii, binary_le, binary_be } format = ascii;
  int64_t count = 0;
  std::vector<Property> props;
  int stride = 0;
  size_t data_start = 0;
};

Header parse_header(const std::string& path, const std::string& bytes) {
  Header h;
  size_t pos = 0;
  int line_no = 0;
  bool have_format = false, in_vertex = false, seen_vertex = false, done = false;
  auto next_line = [&](std::string& line) {
    if (pos >= bytes.size()) return false;
    size_t e = bytes.find('\n', pos);
    if (e == std::string::npos) e = bytes.size();
    line = bytes.substr(pos, e - pos);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    pos = e + 1;
    ++line_no;
    return true;
  };
  std::string line;
  if (!next_line(line) || line != "ply") fail(path, "not a PLY file (no 'ply' magic line)");
  while (!done) {
    if (!next_line(line)) fail(path, "PLY header has no end_header");
    if (pos > (1u << 20)) fail(path, "PLY header longer than 1 MiB");
    std::istringstream ls(line);
    std::string kw;
    ls >> kw;
    const std::string where = "PLY header line " + std::to_string(line_no);
    if (kw.empty() || kw == "comment" || kw == "obj_info") continue;
    if (kw == "format") {
      std::string f, ver;
      ls >> f >> ver;
      if (f == "ascii") h.format = Header::ascii;
      else if (f == "binary_little_endian") h.format = Header::binary_le;
      else if (f == "binary_big_endian") h.format = Header::binary_be;
      else fail(path, where + ": unknown format '" + f + "'");
      have_format = true;
    } else if (kw == "element") {
      std::string name;
      std::string count;
      ls >> name >> count;
      if (seen_vertex) {
        in_vertex = false;  // later elements are not read
        continue;
      }
      if (name != "vertex") fail(path, where + ": the first element must be 'vertex', found '" + name + "'");
      char* end = nullptr;
      errno = 0;
      const long long n = std::strtoll(count.c_str(), &end, 10);
      if (count.empty() || *end != '\0' || errno != 0 || n < 0 || n > (int64_t(1) << 31) - 1)
        fail(path, where + ": bad vertex count '" + count + "'");
      h.count = n;
      seen_vertex = in_vertex = true;
    } else if (kw == "property") {
      if (!seen_vertex) fail(path, where + ": property before any element");
      if (!in_vertex) continue;
      std::string type, name;
      ls >> type;
      if (type == "list") fail(path, where + ": list property in the vertex element is not supported");
      ls >> name;
      PlyType t;
      if (!parse_type(type, t)) fail(path, where + ": unknown property type '" + type + "'");
      if (name.empty()) fail(path, where + ": property without a name");
      for (const auto& p : h.props)
        if (p.name == name) fail(path, where + ": duplicate property '" + name + "'");
      h.props.push_back({name, t, h.stride});
      h.stride += type_size(t);
    } else if (kw == "end_header") {
      done = true;
    } else {
      fail(path, where + ": unexpected keyword '" + kw + "'");
    }
  }
  if (!have_format) fail(path, "PLY header has no format line");
  if (!seen_vertex) fail(path, "PLY file has no vertex element");
  h.data_start = pos;
  return h;
}

}  // namespace

GaussianPly read_ply_3dgs(const std::string& path) {
  std::string bytes;
  {
    std::ifstream f(path, std::ios::binary);
    if (!f) fail(path, "cannot open file");
    std::ostringstream ss;
    ss << f.rdbuf();
    bytes = ss.str();
  }
  const Header h = parse_header(path, bytes);
  std::map<std::string, int> col;
  for (size_t i = 0; i < h.props.size(); ++i) col[h.props[i].name] = int(i);
  auto need = [&](const std::string& name) {
    const auto it = col.find(name);
    if (it == col.end()) fail(path, "missing vertex property '" + name + "'");
    return it->second;
  };
  // f_rest_* must be exactly f_rest_0 .. f_rest_{M-1}.
  int rest_count = 0;
  for (const auto& p : h.props) rest_count += p.name.rfind("f_rest_", 0) == 0;
  for (const auto& p : h.props)
    if (p.name.rfind("f_rest_", 0) == 0) {
      const std::string idx = p.name.substr(7);
      char* end = nullptr;
      const long j = std::strtol(idx.c_str(), &end, 10);
      if (idx.empty() || *end != '\0' || j < 0 || j >= rest_count || std::to_string(j) != idx)
        fail(path, "f_rest properties must be numbered f_rest_0..f_rest_" + std::to_string(rest_count - 1) +
                       ", found '" + p.name + "'");
    }
  int degree = -1;
  for (int d = 0; d <= kMaxShDegree; ++d)
    if (rest_count == 3 * (sh_coeff_count(d) - 1)) degree = d;
  if (degree < 0)
    fail(path, "has " + std::to_string(rest_count) + " f_rest properties; expected 0, 9, 24 or 45 (SH degree 0-3)");
  const int K = sh_coeff_count(degree);

  // Column of each output value, in the order they are stored below.
  std::vector<int> cols;
  for (const char* n : {"x", "y", "z"}) cols.push_back(need(n));
  for (const char* n : {"f_dc_0", "f_dc_1", "f_dc_2"}) cols.push_back(need(n));
  for (int j = 0; j < rest_count; ++j) cols.push_back(need("f_rest_" + std::to_string(j)));
  cols.push_back(need("opacity"));
  for (const char* n : {"scale_0", "scale_1", "scale_2"}) cols.push_back(need(n));
  for (const char* n : {"rot_0", "rot_1", "rot_2", "rot_3"}) cols.push_back(need(n));
  const bool has_normals = col.count("nx") && col.count("ny") && col.count("nz");
  if (has_normals)
    for (const char* n : {"nx", "ny", "nz"}) cols.push_back(col[n]);

  const int64_t N = h.count;
  const size_t nprop = h.props.size();
  // Refuse a count the data cannot hold BEFORE allocating for it: a binary record is
  // `stride` bytes, an ASCII one at least one character and one separator per property.
  const size_t have = bytes.size() - h.data_start;
  const size_t min_record = h.format == Header::ascii ? 2 * nprop : size_t(h.stride);
  const size_t room = h.format == Header::ascii ? have + 1 : have;  // the last separator may be missing
  if (N > 0 && room / min_record < size_t(N))
    fail(path, "element vertex: " + std::to_string(N) + " vertices cannot fit in the " + std::to_string(have) +
                   " bytes after the header (at most " + std::to_string(room / min_record) + "; truncated file?)");
  std::vector<double> rec(nprop);
  GaussianPly g;
  g.sh_degree = degree;
  g.means.resize(3 * N);
  g.sh.resize(size_t(N) * K * 3);
  g.opacity_logit.resize(N);
  g.log_scales.resize(3 * N);
  g.quats.resize(4 * N);
  if (has_normals) g.normals.resize(3 * N);

  const char* text = bytes.data() + h.data_start;
  const char* text_end = bytes.data() + bytes.size();
  const bool swap = (h.format == Header::binary_be) == (std::endian::native == std::endian::little);
  for (int64_t i = 0; i < N; ++i) {
    if (h.format == Header::ascii) {
      for (size_t p = 0; p < nprop; ++p) {
        while (text < text_end && std::isspace(static_cast<unsigned char>(*text))) ++text;
        if (text >= text_end)
          fail(path, "truncated: vertex " + std::to_string(i) + " of " + std::to_string(N) + " is incomplete");
        const char* tok = text;
        while (text < text_end && !std::isspace(static_cast<unsigned char>(*text))) ++text;
        const std::string s(tok, text);
        char* end = nullptr;
        rec[p] = std::strtod(s.c_str(), &end);
        if (end == s.c_str() || *end != '\0')
          fail(path, "vertex " + std::to_string(i) + ": property '" + h.props[p].name + "': not a number '" + s + "'");
      }
    } else {
      const uint8_t* r = reinterpret_cast<const uint8_t*>(bytes.data() + h.data_start) + size_t(i) * h.stride;
      for (size_t p = 0; p < nprop; ++p) rec[p] = load_value(r + h.props[p].offset, h.props[p].type, swap);
    }
    for (int c : cols) {
      const float v = float(rec[size_t(c)]);
      if (!std::isfinite(v))
        fail(path, "vertex " + std::to_string(i) + ": property '" + h.props[size_t(c)].name + "' is not finite (" +
                       std::to_string(rec[size_t(c)]) + ")");
    }
    size_t k = 0;
    auto take = [&] { return float(rec[size_t(cols[k++])]); };
    for (int a = 0; a < 3; ++a) g.means[3 * i + a] = take();
    float* sh = &g.sh[size_t(i) * K * 3];
    for (int c = 0; c < 3; ++c) sh[c] = take();
    for (int c = 0; c < 3; ++c)  // channel-major in the file
      for (int j = 1; j < K; ++j) sh[3 * j + c] = take();
    g.opacity_logit[i] = take();
    for (int a = 0; a < 3; ++a) g.log_scales[3 * i + a] = take();
    for (int a = 0; a < 4; ++a) g.quats[4 * i + a] = take();
    if (has_normals)
      for (int a = 0; a < 3; ++a) g.normals[3 * i + a] = take();
  }
  return g;
}

void write_ply_3dgs(const std::string& path, const GaussianPly& g, bool ascii) {
  const size_t N = size_t(g.size());
  if (g.sh_degree < 0 || g.sh_degree > kMaxShDegree) fail(path, "sh_degree must be 0..3");
  const int K = sh_coeff_count(g.sh_degree);
  if (g.means.size() != 3 * N || g.log_scales.size() != 3 * N || g.quats.size() != 4 * N ||
      g.sh.size() != N * K * 3 || (!g.normals.empty() && g.normals.size() != 3 * N))
    fail(path, "Gaussian arrays have inconsistent sizes");
  std::ostringstream hdr;
  hdr << "ply\nformat " << (ascii ? "ascii" : "binary_little_endian") << " 1.0\nelement vertex " << N << "\n";
  std::vector<std::string> names = {"x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"};
  for (int j = 0; j < 3 * (K - 1); ++j) names.push_back("f_rest_" + std::to_string(j));
  names.push_back("opacity");
  for (const char* n : {"scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"}) names.push_back(n);
  for (const auto& n : names) hdr << "property float " << n << "\n";
  hdr << "end_header\n";
  write_atomically(path, [&](const std::string& tmp) {
    std::ofstream f(tmp, std::ios::binary);
    if (!f) fail(path, "cannot open for writing");
    f << hdr.str();
    std::vector<float> rec(names.size());
    char buf[32];
    for (size_t i = 0; i < N; ++i) {
      size_t k = 0;
      for (int a = 0; a < 3; ++a) rec[k++] = g.means[3 * i + a];
      for (int a = 0; a < 3; ++a) rec[k++] = g.normals.empty() ? 0.f : g.normals[3 * i + a];
      const float* sh = &g.sh[i * K * 3];
      for (int c = 0; c < 3; ++c) rec[k++] = sh[c];
      for (int c = 0; c < 3; ++c)
        for (int j = 1; j < K; ++j) rec[k++] = sh[3 * j + c];
      rec[k++] = g.opacity_logit[i];
      for (int a = 0; a < 3; ++a) rec[k++] = g.log_scales[3 * i + a];
      for (int a = 0; a < 4; ++a) rec[k++] = g.quats[4 * i + a];
      if (ascii) {
        for (size_t j = 0; j < rec.size(); ++j) {
          std::snprintf(buf, sizeof buf, "%.9g", double(rec[j]));
          f << buf << (j + 1 < rec.size() ? ' ' : '\n');
        }
      } else {
        static_assert(std::endian::native == std::endian::little, "binary PLY writer assumes a little-endian host");
        f.write(reinterpret_cast<const char*>(rec.data()), std::streamsize(rec.size() * sizeof(float)));
      }
    }
    if (!f.flush()) fail(path, "write failed");
  });
}

ActivatedPly activate(const GaussianPly& g) {
  ActivatedPly a;
  a.opacities.resize(g.opacity_logit.size());
  a.scales.resize(g.log_scales.size());
  for (size_t i = 0; i < a.opacities.size(); ++i) a.opacities[i] = sigmoid(g.opacity_logit[i]);
  for (size_t i = 0; i < a.scales.size(); ++i) a.scales[i] = std::exp(g.log_scales[i]);
  return a;
}

GaussianInputs<float> ActivatedPly::inputs(const GaussianPly& g) const {
  GaussianInputs<float> in;
  in.count = g.size();
  in.means = g.means.data();
  in.quats = g.quats.data();
  in.scales = scales.data();
  in.opacities = opacities.data();
  in.sh = g.sh.data();
  in.sh_degree = g.sh_degree;
  return in;
}

std::vector<float> render_ply_image(const GaussianPly& g, const Camera& cam, Vec3f background, bool antialiased) {
  const ActivatedPly a = activate(g);
  GaussianRasterSettings<float> settings;
  settings.antialiased = antialiased;
  settings.background_color = background;
  std::vector<float> img(size_t(cam.width) * cam.height * 3);
  GaussianRasterOutputs<float> out;
  out.composite = img.data();
  GaussianRasterState<float> state;
  rasterize_gaussians(a.inputs(g), cam, settings, state, out);
  return img;
}

}  // namespace haha
