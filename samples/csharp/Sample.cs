// Sample.cs: play a motion on a packed avatar from C# through Haha.cs (the C API's binding).
//
//   mono Sample.exe AVATAR.glb MOTION.npz OUTDIR [--size N] [--model BODY_MODEL.npz] [--dump-frame F]
//
// Loads the avatar and the motion (turned upright for it), then for every frame: reposes,
// reads back the posed vertices and all posed Gaussians (means, rotations, scales, colours,
// opacities), renders SIZE x SIZE (default 512) with the built-in renderer and a front
// camera framing the first frame's body (the same camera as samples/c), writes
// OUTDIR/frame_%05d.png and prints the milliseconds of each step. --dump-frame F also writes
// frame F's arrays as raw little-endian binaries (OUTDIR/dump_<name>.bin: float32, faces
// uint32, render bytes) so a test can compare them with the C API's (tests/runtime/
// csharp_sample_slow_test.cpp). Build and run (samples/csharp/README.md):
//
//   mcs -unsafe -out:Sample.exe Haha.cs Sample.cs
//   LD_LIBRARY_PATH=/tmp/haha-prefix/lib mono Sample.exe avatar.glb motion.npz frames/
//
// In Unity the per-frame part is a MonoBehaviour's Update (see the comments in PlayFrame);
// loading goes in Start/Awake and the Dispose calls in OnDestroy.
using System;
using System.Diagnostics;
using System.IO;
using System.Runtime.InteropServices;
using Haha;

static class Sample
{
    static int Main(string[] args)
    {
        string avatarPath = null, motionPath = null, outDir = null, modelPath = null;
        int size = 512, dumpFrame = -1;
        var positional = 0;
        for (int i = 0; i < args.Length; ++i)
        {
            if (args[i] == "--size" && i + 1 < args.Length) size = int.Parse(args[++i]);
            else if (args[i] == "--model" && i + 1 < args.Length) modelPath = args[++i];
            else if (args[i] == "--dump-frame" && i + 1 < args.Length) dumpFrame = int.Parse(args[++i]);
            else if (positional == 0 && !args[i].StartsWith("--")) { avatarPath = args[i]; ++positional; }
            else if (positional == 1 && !args[i].StartsWith("--")) { motionPath = args[i]; ++positional; }
            else if (positional == 2 && !args[i].StartsWith("--")) { outDir = args[i]; ++positional; }
            else { positional = -1; break; }
        }
        if (positional != 3 || size < 1 || size > 16384)
        {
            Console.Error.WriteLine("usage: Sample.exe AVATAR.glb MOTION.npz OUTDIR [--size N (1..16384)] " +
                                    "[--model BODY_MODEL.npz] [--dump-frame F]");
            return 2;
        }
        try
        {
            Run(avatarPath, motionPath, outDir, modelPath, size, dumpFrame);
            return 0;
        }
        catch (HahaException e)
        {
            // e.Message: "<call>: <HAHA_ERROR_...>: <haha_last_error()>", e.g.
            // "haha_avatar_load: HAHA_ERROR_FORMAT: motion.npz: not a .glb file ..."
            Console.Error.WriteLine("Sample: " + e.Message);
            return 1;
        }
        catch (Exception e) when (e is ArgumentException || e is IOException || e is UnauthorizedAccessException)
        {
            Console.Error.WriteLine("Sample: " + e.Message);  // a bad --dump-frame, an OUTDIR that cannot be made
            return 1;
        }
    }

    static void Run(string avatarPath, string motionPath, string outDir, string modelPath, int size, int dumpFrame)
    {
        HahaRuntime.CheckVersion();  // the library's major.minor is the binding's
        Console.WriteLine("haha runtime " + HahaRuntime.VersionString + " (C# binding, " +
                          (Type.GetType("Mono.Runtime") != null ? "Mono" : ".NET") + " " + Environment.Version + ")");

        // Immutable once loaded: an avatar may be shared by every character and thread that
        // shows it; in Unity load it once (Start / a ScriptableObject), e.g.
        // Avatar.LoadMemory(textAsset.bytes) for a .glb shipped as a TextAsset (.bytes).
        using (Avatar avatar = Avatar.Load(avatarPath, modelPath))
        using (Motion motion = Motion.LoadForAvatar(motionPath, avatar))
        using (Posed posed = avatar.CreatePosed())  // one per character (and per thread)
        {
            AvatarInfo info = avatar.Info;
            Console.WriteLine(string.Format("{0}: {1} vertices, {2} faces, {3} Gaussians, texture {4}x{5}{6}", avatarPath,
                                            info.NumVertices, info.NumFaces, info.NumGaussians, info.TextureWidth,
                                            info.TextureHeight, info.MissingPoseCorrectives
                                                ? " (pose correctives missing: pass --model BODY_MODEL.npz)" : ""));
            Console.WriteLine(string.Format("{0}: {1} frames at {2:G3} fps", motionPath, motion.NumFrames, motion.Fps));
            if (dumpFrame >= motion.NumFrames)
                throw new ArgumentException("--dump-frame " + dumpFrame + ": the motion has " + motion.NumFrames + " frames");
            Directory.CreateDirectory(outDir);

            // Pose-independent data, read once: in Unity the Mesh's triangles, UVs and texture.
            uint[] faces = avatar.GetFaces();
            float[] faceUvs = avatar.GetFaceUvs();

            // Buffers reused every frame (no allocation per frame).
            var pose = new float[HahaRuntime.NumPoseValues];
            var translation = new float[3];
            var vertices = new float[3 * info.NumVertices];
            var normals = new float[3 * info.NumVertices];
            var joints = new float[3 * HahaRuntime.NumJoints];
            var gaussians = new GaussianBuffers(info.NumGaussians);
            var rgb = new byte[3 * size * size];
            var white = new float[] { 1, 1, 1 };

            // The camera frames the first frame's posed body.
            motion.GetFrame(0, pose, translation);
            posed.Repose(pose, translation);
            posed.GetVertices(vertices);
            Camera camera = FramingCamera(vertices, size);

            double sumRepose = 0, sumRead = 0, sumRender = 0;
            var clock = new Stopwatch();
            for (int f = 0; f < motion.NumFrames; ++f)
            {
                motion.GetFrame(f, pose, translation);
                clock.Restart();
                posed.Repose(pose, translation);
                double t0 = clock.Elapsed.TotalMilliseconds;
                PlayFrame(posed, vertices, gaussians);
                double t1 = clock.Elapsed.TotalMilliseconds;
                posed.Render(camera, rgb, PixelFormat.Rgb8, white);
                double t2 = clock.Elapsed.TotalMilliseconds;
                string png = Path.Combine(outDir, string.Format("frame_{0:D5}.png", f));
                HahaRuntime.WritePng(png, size, size, 3, rgb);
                Console.WriteLine(string.Format("frame {0,5}: repose {1,7:F2} ms  readback {2,7:F2} ms  render {3,7:F2} ms  -> {4}",
                                                f, t0, t1 - t0, t2 - t1, png));
                sumRepose += t0;
                sumRead += t1 - t0;
                sumRender += t2 - t1;
                if (f == dumpFrame)
                {
                    posed.GetNormals(normals);
                    posed.GetJoints(joints);
                    Dump(outDir, "vertices", vertices);
                    Dump(outDir, "normals", normals);
                    Dump(outDir, "joints", joints);
                    Dump(outDir, "means", gaussians.Means);
                    Dump(outDir, "rotations", gaussians.Rotations);
                    Dump(outDir, "scales", gaussians.Scales);
                    Dump(outDir, "colors", gaussians.Colors);
                    Dump(outDir, "opacities", gaussians.Opacities);
                    Dump(outDir, "faces", faces);
                    Dump(outDir, "face_uvs", faceUvs);
                    Dump(outDir, "texture", avatar.GetTexture());
                    Dump(outDir, "render", rgb);
                    // The camera as haha_camera's 18 numbers (width, height as floats).
                    var cam = new float[20];
                    cam[0] = camera.Width; cam[1] = camera.Height;
                    cam[2] = camera.Fx; cam[3] = camera.Fy; cam[4] = camera.Cx; cam[5] = camera.Cy;
                    Array.Copy(camera.Rotation, 0, cam, 6, 9);
                    Array.Copy(camera.Translation, 0, cam, 15, 3);
                    cam[18] = camera.NearPlane; cam[19] = camera.FarPlane;
                    Dump(outDir, "camera", cam);
                }
            }
            int n = Math.Max(motion.NumFrames, 1);
            Console.WriteLine(string.Format("{0} frames {1}x{1}: mean repose {2:F2} ms, mean readback {3:F2} ms, mean render {4:F2} ms",
                                            motion.NumFrames, size, sumRepose / n, sumRead / n, sumRender / n));
        }  // Dispose: posed, motion, avatar (any order is safe: the posed keeps its avatar's handle)
    }

    // What an engine does every frame after Repose: read the posed mesh and Gaussians back
    // into its own buffers.
    static void PlayFrame(Posed posed, float[] vertices, GaussianBuffers gaussians)
    {
        posed.GetVertices(vertices);
        posed.GetGaussians(gaussians);

        // Unity, the mesh (built once: mesh.MarkDynamic(); mesh.indexFormat = IndexFormat.UInt32;
        // triangles from avatar.GetFaces() with two indices of each triangle swapped; since UVs
        // are per face corner (seams), give Unity one vertex per distinct (vertex, uv) pair and
        // keep a remap array "unityVertex -> haha vertex"):
        //   for (int i = 0; i < remap.Length; ++i) {
        //       int v = remap[i];
        //       unityVerts[i] = new Vector3(-vertices[3 * v], vertices[3 * v + 1], vertices[3 * v + 2]);
        //   }
        //   mesh.SetVertices(unityVerts);            // a Vector3[] or NativeArray<Vector3>, reused
        //   mesh.RecalculateNormals();               // or posed.GetNormals (mirror x the same way)
        //   mesh.RecalculateBounds();
        // The texture once: new Texture2D(w, h, TextureFormat.RGB24, false) and
        // LoadRawTextureData of avatar.GetTexture() with its rows reversed (Unity's first row
        // is the bottom; the face UVs' v already points up).
        //
        // Unity, the Gaussians (a Gaussian-splatting package's per-splat GraphicsBuffers,
        // structured float buffers made once with gaussians.Count elements):
        //   positions: (-mx, my, mz) per Gaussian          <- gaussians.Means
        //   rotations: new Quaternion(x, -y, -z, w)        <- gaussians.Rotations (w, x, y, z)
        //   scales:    as is (linear world std devs; log() them if the package stores logs)
        //   colours and opacities are pose-independent: upload them once (colours are RGB in
        //   [0, 1]; a package storing spherical-harmonics DC wants (rgb - 0.5) / 0.28209479)
        //   positionBuffer.SetData(...); rotationBuffer.SetData(...); scaleBuffer.SetData(...);
        // Repose and these copies may run on a worker thread (a Job or Task per character,
        // each with its own Posed); the GraphicsBuffer / Mesh uploads stay on the main thread.
    }

    // A front camera (looking along world -Z, OpenCV axes: y down) framing the box of the
    // vertices with a 15% margin: samples/c's framing_camera, operation for operation. The
    // (float) casts round every step to float as C does (C# may keep wider intermediates), so
    // the camera, and so the frames, are the C sample's bit for bit.
    static Camera FramingCamera(float[] xyz, int size)
    {
        var lo = new float[] { 1e30f, 1e30f, 1e30f };
        var hi = new float[] { -1e30f, -1e30f, -1e30f };
        for (int v = 0; v < xyz.Length; ++v)
        {
            if (xyz[v] < lo[v % 3]) lo[v % 3] = xyz[v];
            if (xyz[v] > hi[v % 3]) hi[v % 3] = xyz[v];
        }
        var c = new Camera { Width = size, Height = size };
        c.Fx = c.Fy = (float)(1.5f * (float)size);  // ~37 degrees field of view
        c.Cx = c.Cy = (float)(0.5f * (float)size);  // pixel centres at +0.5: the image centre
        var centre = new float[3];
        for (int k = 0; k < 3; ++k) centre[k] = (float)(0.5f * (float)(lo[k] + hi[k]));
        float w = (float)(hi[0] - lo[0]), h = (float)(hi[1] - lo[1]);
        float half = (float)((float)(0.5f * 1.15f) * (w > h ? w : h));
        float dist = (float)((float)((float)(half * c.Fx) / (float)(0.5f * (float)size)) + (float)(0.5f * (float)(hi[2] - lo[2])));
        // R = diag(1, -1, -1): world +Y up becomes image up, the camera looks along world -Z.
        c.Rotation[0] = 1; c.Rotation[1] = 0; c.Rotation[2] = 0;
        c.Rotation[3] = 0; c.Rotation[4] = -1; c.Rotation[5] = 0;
        c.Rotation[6] = 0; c.Rotation[7] = 0; c.Rotation[8] = -1;
        // t = -R eye, eye = centre + (0, 0, dist)
        c.Translation[0] = -centre[0];
        c.Translation[1] = centre[1];
        c.Translation[2] = (float)(centre[2] + dist);
        c.NearPlane = 0.01f;
        c.FarPlane = (float)((float)(4.0f * dist) + 10.0f);
        return c;
    }

    static void Dump<T>(string dir, string name, T[] data) where T : struct
    {
        File.WriteAllBytes(Path.Combine(dir, "dump_" + name + ".bin"),
                           MemoryMarshal.AsBytes(new ReadOnlySpan<T>(data)).ToArray());
    }
}
