// `haha pack`: a trained run directory (RUN/avatar.npz + RUN/config.json "model", see
// app/run_dir.h) -> one .glb avatar (format/spec.md); the driver is app/pack_run.h.
#include <cstdio>
#include <memory>
#include <string>

#include "app/pack_run.h"
#include "command.h"
#include "core/error.h"
#include "format/avatar_pack.h"

HAHA_COMMAND(pack) {
  struct Opts {
    std::string run, out, model, gaussian_bits, mesh_bits, texture = "jpg", corrective_codec, mesh_compression = "draco";
    int texture_size = 0, texture_quality = haha::PackOptions{}.texture_quality;
    bool lossless = false, splats = false, correctives = false, no_correctives = false, keep_face_order = false, normals = false;
    int lod_tiers = 1;
    haha::PackAnimations animations;
    int animation_bits = haha::kDefaultAnimationRotationBits;
  };
  auto o = std::make_shared<Opts>();
  auto* sub = app.add_subcommand("pack", "Pack a trained run into one .glb avatar (skinned textured mesh + Gaussians)");
  sub->add_option("run", o->run, "run directory (avatar.npz + config.json naming the body model), or an avatar.npz with --model")
      ->required();
  sub->add_option("--out", o->out, "output .glb")->required();
  sub->add_option("--model", o->model, "body model .npz (default: config.json's \"model\")");
  sub->add_option("--gaussian-bits", o->gaussian_bits,
                  "Draco quantization bits of the Gaussians: N for all, or offset=14,rotation=12,scale=10,color=8,opacity=8 "
                  "(0 = float32)");
  sub->add_option("--mesh-bits", o->mesh_bits,
                  "Draco quantization bits of the mesh: N for all, or position=16,normal=10,texcoord=14,weight=12");
  sub->add_option("--texture", o->texture, "texture image format: png (lossless 8-bit), jpg or webp")->capture_default_str();
  sub->add_option("--texture-size", o->texture_size, "resample the texture to N x N (default: trained size)");
  sub->add_option("--texture-quality", o->texture_quality,
                  "jpg/webp quality 1..100 (default: 90 for textures up to 512^2, 75 for larger ones)")
      ->check(CLI::Range(0, 100));
  sub->add_flag("--lossless", o->lossless, "float32 everywhere + exact texture copy: unpack restores every parameter bit-exact");
  sub->add_flag("--khr-gaussian-splatting", o->splats,
                "also store the Gaussians in the rest pose as a KHR_gaussian_splatting primitive (splat viewers)");
  sub->add_option("--mesh-compression", o->mesh_compression,
                  "draco: the body mesh Draco-compressed (smallest; viewers need a Draco decoder); none: plain accessors and "
                  "no required extension, for engines and tools without Draco (Blender and Godot as Debian ships them)")
      ->check(CLI::IsMember({"draco", "none"}))
      ->capture_default_str();
  sub->add_flag("--keep-face-order", o->keep_face_order,
                "Draco sequential mesh encoding: the file keeps the body model's face order (about 3.5x larger mesh)");
  sub->add_flag("--normals", o->normals, "store vertex normals (8-bit octahedral); the unlit material does not need them");
  sub->add_option("--lod", o->lod_tiers,
                  "store the Gaussians in N importance tiers (prefixes N/2^(T-1) .. all) so a loader can take a prefix; each "
                  "prefix's PSNR against the full avatar is measured and stored");
  sub->add_flag("--pose-correctives", o->correctives,
                "embed the pose correctives dense (int16; float32 with --lossless, exact; megabytes) instead of the "
                "compact default (lossless packs embed none without this flag)");
  sub->add_flag("--no-pose-correctives", o->no_correctives,
                "embed no pose correctives (a loader then needs the body model to repose like the trainer)");
  sub->add_option("--pose-corrective-codec", o->corrective_codec,
                  "compact pose correctives: t=threshold (relative block norm kept per joint), r=rank per joint (1..9), "
                  "b=coefficient bits (0 = float32), e=energy kept per joint (sets the rank, at most r), e.g. t=0.02,r=4,e=0.995,b=6");
  sub->add_option("--animation", o->animations.files,
                  "a motion .npz (haha motion, AMASS, SMPL-X parameters) stored as a glTF animation of the joints; repeatable")
      ->take_all()
      ->allow_extra_args(false);
  sub->add_option("--animation-name", o->animations.names, "name of each --animation, in order (default: the file's stem)")
      ->take_all()
      ->allow_extra_args(false);
  sub->add_option("--animation-rate", o->animations.rate, "resample the animations to this many frames per second (default: the motion's rate)");
  sub->add_option("--animation-tolerance", o->animations.tolerance,
                  "keyframe reduction: drop keys that linear interpolation of the kept ones reproduces within this many "
                  "radians (root translation: metres); 0 keeps every key")
      ->capture_default_str();
  sub->add_option("--animation-bits", o->animation_bits,
                  "bits per stored rotation component: 16 (normalized short), 8 (normalized byte) or 0 (float32)")
      ->capture_default_str();
  sub->callback([o] {
    haha::PackOptions opt;
    opt.animation_bits = o->animation_bits;
    if (o->animations.files.empty() && !o->animations.names.empty()) haha::fail("--animation-name", "needs --animation");
    opt.lossless = o->lossless;
    opt.texture_codec = haha::texture_codec_from_name(o->texture);
    opt.texture_size = o->texture_size;
    opt.texture_quality = o->texture_quality;
    opt.khr_gaussian_splatting = o->splats;
    if (o->correctives && o->no_correctives) haha::fail("--pose-correctives", "cannot be combined with --no-pose-correctives");
    opt.pose_correctives = o->correctives      ? haha::PoseCorrectives::dense
                           : o->no_correctives ? haha::PoseCorrectives::none
                                               : haha::PoseCorrectives::compact;
    if (!o->corrective_codec.empty()) {
      opt.pose_corrective_codec = haha::parse_pose_corrective_codec(o->corrective_codec, "--pose-corrective-codec");
    }
    opt.keep_face_order = o->keep_face_order;
    opt.mesh_compression = o->mesh_compression == "none" ? haha::MeshCompression::none : haha::MeshCompression::draco;
    opt.normals = o->normals;
    opt.lod_tiers = o->lod_tiers;
    if (o->texture_size < 0) haha::fail("--texture-size", "must be positive");
    if (!o->gaussian_bits.empty()) {
      opt.gaussian_bits = haha::parse_gaussian_bits(o->gaussian_bits, "--gaussian-bits");
    }
    if (!o->mesh_bits.empty()) {
      opt.mesh_bits = haha::parse_mesh_bits(o->mesh_bits, "--mesh-bits");
    }
    if (o->lossless && (!o->gaussian_bits.empty() || !o->mesh_bits.empty())) {
      haha::fail("--lossless", "stores float32 everywhere; it cannot be combined with --gaussian-bits/--mesh-bits");
    }
    const haha::PackedSizes s = haha::pack_run(o->run, o->model, o->out, opt, o->animations);
    std::printf("%s: %zu bytes: %d Gaussians %zu B, mesh (%d vertices, %d faces) %zu B, texture %zu B%s, pose correctives %zu B\n",
                o->out.c_str(), s.total, s.num_gaussians, s.gaussians, s.num_vertices, s.num_faces, s.mesh, s.texture,
                o->lossless ? " (+ exact copy)" : "", s.pose_correctives);
    if (!o->animations.files.empty()) std::printf("%s: %zu animation(s) %zu B\n", o->out.c_str(), o->animations.files.size(), s.animations);
  });
}
