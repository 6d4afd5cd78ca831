// `haha render-ply`: renders a standard 3DGS .ply scene (see io/ply_3dgs.h) from one camera
// (cam.json, see io/camera_json.h) into an image, the way the reference 3DGS rasterizer does.
#include <cmath>
#include <cstdio>
#include <memory>
#include <sstream>
#include <string>

#include "app/render_ply.h"
#include "command.h"
#include "io/camera_json.h"
#include "io/image.h"
#include "parse_rgb.h"


HAHA_COMMAND(render_ply) {
  struct Opts {
    std::string scene, camera, out, background = "0,0,0", device = "cpu";
    bool antialiased = false;
  };
  auto o = std::make_shared<Opts>();
  auto* sub = app.add_subcommand("render-ply", "Render a standard 3DGS .ply scene from a camera into an image");
  sub->add_option("scene", o->scene, "3DGS .ply (x,y,z, f_dc_*, f_rest_*, opacity, scale_*, rot_*)")->required();
  sub->add_option("--camera", o->camera,
                  "cam.json: {\"width\",\"height\",\"K\":3x3,\"world_to_camera\":4x4 (OpenCV), \"near\",\"far\"}")
      ->required();
  sub->add_option("--out", o->out, "output image: .png/.jpg (8-bit, clamped), .exr, .tif (float)")->required();
  sub->add_option("--background", o->background, "background colour r,g,b in [0, 1]")->capture_default_str();
  sub->add_flag("--antialiased", o->antialiased, "mip-splatting opacity compensation (off in reference 3DGS)");
  sub->add_option("--device", o->device, "cpu or cuda (the same rasterizer on the GPU)")->capture_default_str();
  sub->callback([o] {
    const haha::Device device = haha::parse_device(o->device);
    const haha::Vec3f bg = haha::cli::parse_rgb(o->background);
    const haha::Camera cam = haha::read_camera_json(o->camera);
    const haha::GaussianPly scene = haha::read_ply_3dgs(o->scene);
    haha::Image img(cam.width, cam.height, 3);
    img.data = haha::render_ply_on(device, scene, cam, bg, o->antialiased);
    haha::write_image(o->out, img);
    std::printf("%s: %dx%d, %d Gaussians (SH degree %d)\n", o->out.c_str(), cam.width, cam.height, scene.size(),
                scene.sh_degree);
  });
}
