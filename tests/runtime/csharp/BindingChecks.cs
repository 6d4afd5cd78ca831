// Checks of samples/csharp/Haha.cs beyond what Sample.cs exercises: errors become
// HahaExceptions with the library's message, capacities, wrong call order, the SafeHandles'
// lifetimes (an avatar disposed before its pose state, forgotten objects finalized), pose
// states on several threads, the per-thread last error, float renders, memory / LOD loads.
// Run by tests/runtime/csharp_sample_slow_test.cpp:
//
//   mcs -unsafe -out:BindingChecks.exe samples/csharp/Haha.cs tests/runtime/csharp/BindingChecks.cs
//   LD_LIBRARY_PATH=<dir of libhaha_runtime.so> mono BindingChecks.exe AVATAR.glb MOTION.npz OUTDIR
//
// Prints one line per failed check and "N passed, M failed"; exit status 1 if any failed.
using System;
using System.IO;
using System.Linq;
using System.Threading;
using Haha;

static class BindingChecks
{
    static int passed, failed;

    static void Expect(bool ok, string what)
    {
        if (ok) ++passed;
        else
        {
            ++failed;
            Console.WriteLine("FAILED: " + what);
        }
    }

    // The action throws T (and, for a HahaException, with that status and text in its message).
    static void Throws<T>(Action action, string what, HahaStatus status = HahaStatus.Ok, string text = null)
        where T : Exception
    {
        try
        {
            action();
            Expect(false, what + ": no exception");
        }
        catch (T e)
        {
            var h = e as HahaException;
            bool ok = h == null || status == HahaStatus.Ok || h.Status == status;
            ok &= text == null || e.Message.Contains(text);
            Expect(ok, what + ": " + e.GetType().Name + ": " + e.Message);
        }
        catch (Exception e)
        {
            Expect(false, what + ": unexpected " + e.GetType().Name + ": " + e.Message);
        }
    }

    static int Main(string[] args)
    {
        if (args.Length != 3)
        {
            Console.Error.WriteLine("usage: BindingChecks.exe AVATAR.glb MOTION.npz OUTDIR");
            return 2;
        }
        string glb = args[0], motionPath = args[1], outDir = args[2];
        Directory.CreateDirectory(outDir);

        // Version and status strings.
        HahaRuntime.CheckVersion();
        Expect(HahaRuntime.VersionString == HahaRuntime.Version.ToString(), "version string " + HahaRuntime.VersionString);
        Expect(HahaRuntime.StatusString(HahaStatus.ErrorIO) == "HAHA_ERROR_IO", "status string");
        Expect(HahaRuntime.StatusString((HahaStatus)99) == "unknown status", "unknown status string");

        // Errors: status, call and the library's line naming the file.
        string missing = Path.Combine(outDir, "no such avatar.glb");
        Throws<HahaException>(() => Avatar.Load(missing), "missing file", HahaStatus.ErrorIO, missing);
        try { Avatar.Load(missing); }
        catch (HahaException e) { Expect(e.Call == "haha_avatar_load" && e.Message.StartsWith("haha_avatar_load: HAHA_ERROR_IO: "), "exception text: " + e.Message); }
        Throws<HahaException>(() => Avatar.Load(motionPath), "not a .glb", HahaStatus.ErrorFormat, motionPath);
        Throws<HahaException>(() => Avatar.LoadMemory(new byte[] { 1, 2, 3 }, "bytes.glb"), "bad memory", HahaStatus.ErrorFormat, "bytes.glb");
        Throws<HahaException>(() => Motion.Load(glb), "not a motion", HahaStatus.ErrorFormat, glb);
        Throws<HahaException>(() => HahaRuntime.SetNumThreads(0), "0 threads", HahaStatus.ErrorArgument);
        HahaRuntime.SetNumThreads(2);
        Expect(HahaRuntime.LastError == "", "last error cleared by a success: '" + HahaRuntime.LastError + "'");
        // Non-ASCII path: UTF-8 both ways.
        string accented = Path.Combine(outDir, "avätar ✓.glb");
        File.Copy(glb, accented, true);

        using (Avatar avatar = Avatar.Load(accented))
        using (Avatar fromMemory = Avatar.LoadMemory(File.ReadAllBytes(glb), "mem.glb"))
        using (Avatar lod = Avatar.LoadLod(glb, 10))
        using (Motion motion = Motion.LoadForAvatar(motionPath, avatar))
        using (Motion asStored = Motion.Load(motionPath))
        {
            AvatarInfo info = avatar.Info;
            Expect(info.NumVertices > 0 && info.NumFaces > 0 && info.NumGaussians > 0 && info.NumJoints == 55, "info counts");
            Expect(fromMemory.Info.NumGaussians == info.NumGaussians && fromMemory.Info.NumFaces == info.NumFaces, "memory load");
            Expect(lod.Info.NumGaussians > 0 && lod.Info.NumGaussians <= info.NumGaussians, "LOD load");
            Expect(avatar.GetInfo().NumVertices == info.NumVertices, "GetInfo");
            Expect(avatar.GetFaces().Max() < (uint)info.NumVertices, "faces index the vertices");
            Expect(avatar.GetFaceUvs().Length == 6 * info.NumFaces, "face UVs");
            Expect(avatar.GetTexture().Length == 3 * info.TextureWidth * info.TextureHeight, "texture");
            // The sample avatar has no mesh coverage: 1 everywhere, the flag off.
            Expect(!avatar.HasMeshCoverage && avatar.GetMeshCoverage().Length == info.NumVertices &&
                   avatar.GetMeshCoverage().All(c => c == 1.0f), "mesh coverage");
            Expect(motion.NumFrames == asStored.NumFrames && motion.NumFrames >= 2 && motion.Fps > 0, "motion info");

            var pose = new float[HahaRuntime.NumPoseValues];
            var transl = new float[3];
            Throws<HahaException>(() => motion.GetFrame(motion.NumFrames, pose, transl), "frame out of range",
                                  HahaStatus.ErrorArgument);
            Throws<ArgumentException>(() => motion.GetFrame(0, new float[10], transl), "short pose buffer");
            motion.GetFrame(1, pose, null);  // translation skipped

            using (Posed posed = avatar.CreatePosed())
            {
                Throws<HahaException>(() => posed.GetVertices(), "read before repose", HahaStatus.ErrorState);
                Throws<ArgumentException>(() => posed.Repose(new float[10], null), "short pose");
                Throws<ArgumentException>(() => posed.Repose(pose, new float[2]), "short translation");
                Throws<HahaException>(() => posed.Repose(pose, null, new float[10], null), "betas refused",
                                      HahaStatus.ErrorArgument, "betas");
                posed.Repose(null, null);  // rest
                float[] rest = posed.GetVertices();
                posed.Repose(pose, transl);
                float[] v = posed.GetVertices();
                Expect(!v.SequenceEqual(rest), "a pose moves the body");
                // Too small: ErrorArgument, nothing written.
                var small = new float[3 * info.NumVertices - 1];
                for (int i = 0; i < small.Length; ++i) small[i] = 7;
                Throws<HahaException>(() => posed.GetVertices(small), "small vertex buffer", HahaStatus.ErrorArgument);
                Expect(small.All(x => x == 7), "nothing written into a small buffer");
                var opac = new float[info.NumGaussians - 1];
                Throws<HahaException>(() => posed.GetGaussians(null, null, null, null, opac), "small Gaussian buffer",
                                      HahaStatus.ErrorArgument);
                // One array alone (the others NULL) matches the full read.
                GaussianBuffers all = posed.GetGaussians();
                var means = new float[3 * info.NumGaussians];
                posed.GetGaussians(means, null, null, null, null);
                Expect(means.SequenceEqual(all.Means), "means alone");
                float[] normals = posed.GetNormals();
                Expect(Math.Abs(normals[0] * normals[0] + normals[1] * normals[1] + normals[2] * normals[2] - 1) < 1e-4,
                       "unit normal");
                Expect(posed.GetJoints().Length == 165, "joints");

                // Float render vs 8-bit: 8-bit = round(255 clamp(v)).
                var cam = new Camera { Width = 24, Height = 32, Fx = 40, Fy = 40, Cx = 12, Cy = 16, NearPlane = 0.01f, FarPlane = 50 };
                cam.Rotation[4] = -1; cam.Rotation[8] = -1;  // looking along world -Z, y down
                cam.Translation[1] = 0.3f; cam.Translation[2] = 3;
                var rgba = new float[4 * 24 * 32];
                var rgb8 = new byte[3 * 24 * 32];
                var bg = new float[] { 0.2f, 0.4f, 0.6f };
                posed.Render(cam, rgba, PixelFormat.Rgba32F, bg);
                posed.Render(cam, rgb8, PixelFormat.Rgb8, bg);
                bool same = true;
                int covered = 0;
                for (int p = 0; p < 24 * 32; ++p)
                {
                    covered += rgba[4 * p + 3] > 0.5f ? 1 : 0;
                    for (int k = 0; k < 3; ++k)
                        same &= rgb8[3 * p + k] == (byte)Math.Round(255 * Math.Min(Math.Max(rgba[4 * p + k], 0f), 1f),
                                                                    MidpointRounding.AwayFromZero);
                }
                Expect(same, "8-bit render = rounded float render");
                Expect(covered > 10, "the camera sees the body (" + covered + " pixels)");
                Throws<HahaException>(() => posed.Render(cam, new byte[3 * 24 * 32 - 1]), "small pixel buffer",
                                      HahaStatus.ErrorArgument);
                posed.Render(cam, rgb8, PixelFormat.Rgb8, null, RenderFlags.NoGaussians);
                Throws<ArgumentException>(() => HahaRuntime.WritePng(Path.Combine(outDir, "x.png"), 24, 32, 3, new byte[10]),
                                          "short PNG pixels");
                Throws<HahaException>(() => HahaRuntime.WritePng(Path.Combine(outDir, "x.jpg"), 24, 32, 3, rgb8),
                                      "PNG path without .png", HahaStatus.ErrorArgument);
            }

            // Several pose states of one avatar on several threads: each thread's results
            // equal the sequential ones; a failure's message stays with its thread.
            int frames = motion.NumFrames;
            var expected = new float[frames][];
            using (Posed posed = avatar.CreatePosed())
            {
                for (int f = 0; f < frames; ++f)
                {
                    motion.GetFrame(f, pose, transl);
                    posed.Repose(pose, transl);
                    expected[f] = posed.GetVertices();
                }
            }
            var threadOk = new bool[4];
            var threads = new Thread[4];
            for (int t = 0; t < 4; ++t)
            {
                int id = t;
                threads[t] = new Thread(() =>
                {
                    bool ok = true;
                    try
                    {
                        HahaRuntime.SetNumThreads(1);  // per calling thread: no OpenMP oversubscription
                        var p = new float[HahaRuntime.NumPoseValues];
                        var tr = new float[3];
                        using (Posed mine = avatar.CreatePosed())
                        {
                            for (int round = 0; round < 2; ++round)
                                for (int f = 0; f < frames; ++f)
                                {
                                    int frame = (f + id) % frames;
                                    motion.GetFrame(frame, p, tr);
                                    mine.Repose(p, tr);
                                    ok &= mine.GetVertices().SequenceEqual(expected[frame]);
                                }
                            if (id == 0)
                            {
                                try { mine.GetVertices(new float[1]); ok = false; }
                                catch (HahaException) { }
                                Thread.Sleep(50);  // the others succeed meanwhile
                                ok &= HahaRuntime.LastError.Contains("haha_posed_vertices");
                            }
                        }
                    }
                    catch (Exception e)
                    {
                        Console.WriteLine("thread " + id + ": " + e);
                        ok = false;
                    }
                    threadOk[id] = ok;
                });
                threads[t].Start();
            }
            foreach (Thread th in threads) th.Join();
            Expect(threadOk.All(x => x), "threads: " + string.Join(",", threadOk));
        }

        // Lifetimes. An avatar disposed before its pose state: the pose state still works
        // (its handle keeps the native avatar), the avatar refuses new calls.
        {
            Avatar avatar = Avatar.Load(glb);
            Posed posed = avatar.CreatePosed();
            posed.Repose(null, null);
            float[] before = posed.GetVertices();
            avatar.Dispose();
            Throws<ObjectDisposedException>(() => avatar.CreatePosed(), "disposed avatar");
            Throws<ObjectDisposedException>(() => avatar.GetFaces(), "disposed avatar getter");
            posed.Repose(null, null);
            Expect(posed.GetVertices().SequenceEqual(before), "pose state outlives its disposed avatar");
            posed.Dispose();  // frees the native pose state, then the avatar
            Throws<ObjectDisposedException>(() => posed.GetVertices(), "disposed pose state");
            posed.Dispose();  // twice: no-op
            avatar.Dispose();
        }
        // Forgotten objects are finalized (in any order) without a crash.
        for (int round = 0; round < 2; ++round)
        {
            for (int i = 0; i < 5; ++i)
            {
                Avatar a = Avatar.Load(glb);
                Posed p = a.CreatePosed();
                p.Repose(null, null);
                Motion.LoadForAvatar(motionPath, a);
            }
            GC.Collect();
            GC.WaitForPendingFinalizers();
            GC.Collect();
        }
        Expect(true, "finalizers");

        Console.WriteLine(passed + " passed, " + failed + " failed");
        return failed == 0 ? 0 : 1;
    }
}
