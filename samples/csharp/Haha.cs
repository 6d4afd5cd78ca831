// Haha.cs: a C# binding of libhaha_runtime, the haha avatar runtime's C API
// (runtime/include/haha/haha_runtime.h, API 0.1; the header's comments are the reference).
//
// One file, no dependency beyond the base class library (System.Memory's Span<T>, in
// mscorlib on Mono 6 / .NET Core 2.1+ / Unity 2021.2+). It needs unsafe code: mcs -unsafe,
// <AllowUnsafeBlocks>true</AllowUnsafeBlocks>, or in Unity "Allow 'unsafe' Code" (Player
// settings, or the .asmdef this file lives in).
//
//   using (var avatar = Haha.Avatar.Load("avatar.glb"))
//   using (var posed = avatar.CreatePosed())
//   {
//       var pose = new float[Haha.HahaRuntime.NumPoseValues];
//       pose[3 * 16 + 2] = -1.0f;                        // left shoulder (joint 16) down
//       posed.Repose(pose, null);                        // null / empty: rest pose, no translation
//       float[] xyz = posed.GetVertices();               // V x 3, or posed.GetVertices(span)
//   }                                                    // errors: Haha.HahaException
//
// What maps to what:
//   - haha_avatar / haha_posed / haha_motion: Avatar / Posed / Motion (IDisposable), each
//     over a SafeHandle (AvatarHandle / PosedHandle / MotionHandle) that frees the native
//     object when disposed or, if forgotten, when finalized. A PosedHandle holds a
//     reference on its AvatarHandle, so the header's rule "free an avatar only after its
//     pose states" holds whatever order Dispose or the finalizer runs in: disposing an
//     Avatar while a Posed of it lives only defers the native free.
//   - haha_status != HAHA_OK: a HahaException with the Status and haha_last_error()'s line
//     (read on the failing thread right after the call; it is per thread).
//   - caller buffers: Span<T> (arrays convert implicitly) with the span's length passed as
//     the capacity in the header's units (elements; bytes for Render; Gaussians for
//     GetGaussians), so a too-small span is HahaStatus.ErrorArgument from the library and
//     nothing is written. Each Get* also has an allocating overload returning an array.
//     Fixed-size inputs the library cannot check (pose 165, translation 3, a PNG's pixels)
//     are checked here: ArgumentException.
//   - strings (paths, names) go in as NUL-terminated UTF-8; strings coming back are UTF-8.
//   - Native: the raw P/Invoke declarations, one per C function, for code that wants them.
//
// Threads (the header's "Threads"): Avatar and Motion are immutable after loading, any
// number of threads may use one at a time (getters, CreatePosed, GetFrame). A Posed is one
// pose state: one thread at a time (Repose, Get*, Render must not overlap on the same
// Posed); distinct Posed objects, even of one Avatar, may run concurrently: one per
// character or per worker thread (a Unity Job / Task). Repose and Render are OpenMP-
// parallel inside (HahaRuntime.SetNumThreads, per calling thread).
//
// Unity (no Unity API is used here): put this file under Assets/Plugins/ (or any folder of
// scripts) and libhaha_runtime.so under Assets/Plugins/x86_64/ (Linux Editor / Standalone;
// its Inspector: Linux x86_64 ticked). [DllImport("haha_runtime")] finds
// libhaha_runtime.so there, as Mono and .NET do on Linux through the loader's search path
// (LD_LIBRARY_PATH). A copy of libhaha_runtime.so.0.1.0 renamed libhaha_runtime.so works:
// the library is loaded by path, its SONAME does not matter. Its own dependencies
// (OpenImageIO, libzip, Draco, libgomp) must be installed on the machine (Debian packages).
// An IL2CPP build on a platform that links plugins statically (iOS) would use
// DllImport("__Internal") instead: change LibraryName.
//
// Conventions (docs/architecture.md "Conventions"): SMPL-X rest frame, metres, right-handed, Y up, body
// facing +Z; quaternions (w, x, y, z). Unity is left-handed (Y up, Z forward): mirror X,
// i.e. position (x, y, z) -> new Vector3(-x, y, z), quaternion (w, x, y, z) ->
// new Quaternion(x, -y, -z, w), and swap two indices of each triangle (winding). Scales
// stay as they are. Sample.cs shows where those conversions go.
using System;
using System.Runtime.InteropServices;
using System.Text;
using Microsoft.Win32.SafeHandles;

namespace Haha
{
    /// <summary>haha_status.</summary>
    public enum HahaStatus
    {
        Ok = 0,
        ErrorArgument = 1,    // NULL, a value out of range, a buffer too small, an option that cannot be honoured
        ErrorIO = 2,          // a file could not be opened, read or written
        ErrorFormat = 3,      // a file's contents are invalid
        ErrorState = 4,       // wrong call order (reading a pose state never reposed)
        ErrorOutOfMemory = 5,
        ErrorInternal = 6,    // a bug: please report the message
    }

    /// <summary>haha_pixel_format: 8-bit (0..255) or the renderer's float values.</summary>
    public enum PixelFormat
    {
        Rgb8 = 0,
        Rgba8 = 1,
        Rgb32F = 2,
        Rgba32F = 3,
    }

    /// <summary>haha_render flags: draw only one layer.</summary>
    [Flags]
    public enum RenderFlags : uint
    {
        None = 0,
        NoMesh = 1,       // HAHA_RENDER_NO_MESH: Gaussians only
        NoGaussians = 2,  // HAHA_RENDER_NO_GAUSSIANS: textured mesh only
    }

    /// <summary>A failed haha_* call: its status and the library's one-line message
    /// (haha_last_error(), e.g. "avatar.glb: gaussians: checksum mismatch").</summary>
    public sealed class HahaException : Exception
    {
        public HahaStatus Status { get; }
        /// <summary>The C function that failed, e.g. "haha_avatar_load".</summary>
        public string Call { get; }

        public HahaException(HahaStatus status, string call, string message)
            : base(call + ": " + HahaRuntime.StatusString(status) + ": " + message)
        {
            Status = status;
            Call = call;
        }
    }

    /// <summary>haha_avatar_info: counts and metadata of a loaded avatar.</summary>
    [StructLayout(LayoutKind.Sequential)]
    public struct AvatarInfo
    {
        public int NumVertices;    // V: body vertices (the file's body-vertex order)
        public int NumFaces;       // F: triangles
        public int NumGaussians;   // N
        public int NumJoints;      // 55
        public int TextureWidth;   // pixels; 0 without a texture
        public int TextureHeight;
        int hasPoseCorrectives;
        int missingPoseCorrectives;

        /// <summary>Reposes apply pose-corrective blend shapes (embedded, or from the body model).</summary>
        public bool HasPoseCorrectives { get { return hasPoseCorrectives != 0; } }
        /// <summary>Trained with pose correctives this runtime lacks: pass the body model to match the trainer.</summary>
        public bool MissingPoseCorrectives { get { return missingPoseCorrectives != 0; } }
    }

    /// <summary>An OpenCV pinhole camera (haha_camera): x right, y down, z forward;
    /// x_cam = Rotation * x_world + Translation; pixel = (Fx x/z + Cx, Fy y/z + Cy) with
    /// pixel centres at +0.5 (a centred principal point is Cx = Width / 2).</summary>
    public sealed class Camera
    {
        public int Width, Height;      // pixels, 1..16384
        public float Fx, Fy, Cx, Cy;   // intrinsics in pixels
        /// <summary>World-to-camera rotation, 9 floats, row-major.</summary>
        public readonly float[] Rotation = { 1, 0, 0, 0, 1, 0, 0, 0, 1 };
        /// <summary>World-to-camera translation, 3 floats.</summary>
        public readonly float[] Translation = new float[3];
        public float NearPlane, FarPlane;   // clip distances along z; <= 0 selects 0.01 / 100

        internal unsafe Native.haha_camera ToNative()
        {
            if (Rotation.Length != 9 || Translation.Length != 3)
                throw new ArgumentException("Camera: Rotation needs 9 floats, Translation 3");
            var c = new Native.haha_camera
            {
                width = Width, height = Height, fx = Fx, fy = Fy, cx = Cx, cy = Cy,
                near_plane = NearPlane, far_plane = FarPlane,
            };
            for (int i = 0; i < 9; ++i) c.rotation[i] = Rotation[i];
            for (int i = 0; i < 3; ++i) c.translation[i] = Translation[i];
            return c;
        }
    }

    /// <summary>Posed Gaussians as a structure of arrays, sized for an avatar's N Gaussians
    /// (Posed.GetGaussians fills it). Colours and opacities are pose-independent.</summary>
    public sealed class GaussianBuffers
    {
        public readonly int Count;
        public readonly float[] Means;      // N x 3: world centres
        public readonly float[] Rotations;  // N x 4: world rotations, unit quaternions (w, x, y, z)
        public readonly float[] Scales;     // N x 3: world standard deviations (linear, metres)
        public readonly float[] Colors;     // N x 3: RGB in [0, 1] (view-independent)
        public readonly float[] Opacities;  // N: in [0, 1]

        public GaussianBuffers(int count)
        {
            if (count < 0) throw new ArgumentOutOfRangeException("count");
            Count = count;
            Means = new float[3 * count];
            Rotations = new float[4 * count];
            Scales = new float[3 * count];
            Colors = new float[3 * count];
            Opacities = new float[count];
        }
    }

    /// <summary>Library-wide calls: version, errors, threads, PNG writing.</summary>
    public static class HahaRuntime
    {
        /// <summary>The header version this binding was written against.</summary>
        public const int ApiVersionMajor = 0, ApiVersionMinor = 1, ApiVersionPatch = 0;
        /// <summary>HAHA_NUM_JOINTS: SMPL-X skin joints.</summary>
        public const int NumJoints = 55;
        /// <summary>HAHA_NUM_POSE_VALUES: 55 joints x axis-angle.</summary>
        public const int NumPoseValues = 165;
        /// <summary>HAHA_MESH_COVERAGE_CUTOFF: the mesh draws where its interpolated coverage is >= this.</summary>
        public const float MeshCoverageCutoff = 0.5f;

        /// <summary>The loaded library's version (haha_version).</summary>
        public static Version Version
        {
            get
            {
                int major, minor, patch;
                Native.haha_version(out major, out minor, out patch);
                return new Version(major, minor, patch);
            }
        }

        /// <summary>"0.1.0" (haha_version_string).</summary>
        public static string VersionString { get { return Native.Utf8String(Native.haha_version_string()); } }

        /// <summary>The calling thread's last error (haha_last_error): "" after a success.</summary>
        public static string LastError { get { return Native.Utf8String(Native.haha_last_error()); } }

        /// <summary>"HAHA_OK", "HAHA_ERROR_IO", ... (haha_status_string).</summary>
        public static string StatusString(HahaStatus status)
        {
            return Native.Utf8String(Native.haha_status_string(status));
        }

        /// <summary>Throws unless the loaded library has this binding's major.minor (0.x:
        /// no ABI promise across minor versions). Call once before anything else.</summary>
        public static void CheckVersion()
        {
            Version v = Version;
            if (v.Major != ApiVersionMajor || v.Minor != ApiVersionMinor)
                throw new HahaException(HahaStatus.ErrorArgument, "haha_version",
                    "libhaha_runtime " + v + " loaded, this binding needs " + ApiVersionMajor + "." + ApiVersionMinor + ".x");
        }

        /// <summary>OpenMP threads used by Repose and Render started from the calling thread.</summary>
        public static void SetNumThreads(int n)
        {
            Native.Check(Native.haha_set_num_threads(n), "haha_set_num_threads");
        }

        /// <summary>Writes 8-bit pixels (height rows of width x channels bytes, top row first;
        /// channels 1 grey, 2 grey+alpha, 3 RGB, 4 RGBA) as a PNG; the path ends in ".png".</summary>
        public static unsafe void WritePng(string path, int width, int height, int channels, ReadOnlySpan<byte> pixels)
        {
            if (width < 1 || height < 1 || channels < 1 || channels > 4)
                throw new ArgumentException("WritePng: width, height >= 1 and channels 1..4 expected");
            if ((long)pixels.Length < (long)width * height * channels)
                throw new ArgumentException("WritePng: " + pixels.Length + " bytes for " + width + "x" + height + "x" + channels);
            fixed (byte* p = &MemoryMarshal.GetReference(pixels))
                Native.Check(Native.haha_write_png(Native.Utf8z(path), width, height, channels, p), "haha_write_png");
        }
    }

    /// <summary>A loaded avatar (haha_avatar): immutable, shareable between threads.</summary>
    public sealed class Avatar : IDisposable
    {
        /// <summary>The native handle (for Native calls).</summary>
        public AvatarHandle Handle { get; }
        /// <summary>Counts and metadata, read once at load.</summary>
        public AvatarInfo Info { get; }

        Avatar(AvatarHandle handle)
        {
            Handle = handle;
            AvatarInfo info;
            Native.Check(Native.haha_avatar_get_info(handle, out info), "haha_avatar_get_info");
            Info = info;
        }

        static Avatar Wrap(HahaStatus status, AvatarHandle handle, string call)
        {
            if (status != HahaStatus.Ok)
            {
                string message = HahaRuntime.LastError;
                if (handle != null) handle.Dispose();
                throw new HahaException(status, call, message);
            }
            return new Avatar(handle);
        }

        /// <summary>Loads and validates a .glb avatar. bodyModelPath (may be null): the SMPL-X
        /// model .npz it was trained with, for pose correctives the file does not embed.</summary>
        public static Avatar Load(string path, string bodyModelPath = null)
        {
            AvatarHandle h;
            HahaStatus s = Native.haha_avatar_load(Native.Utf8z(path), Native.Utf8z(bodyModelPath), out h);
            return Wrap(s, h, "haha_avatar_load");
        }

        /// <summary>The same from the file's bytes (decoded during the call; e.g. a
        /// TextAsset's bytes in Unity). name (may be null) names the buffer in errors.</summary>
        public static unsafe Avatar LoadMemory(ReadOnlySpan<byte> data, string name = null, string bodyModelPath = null)
        {
            AvatarHandle h;
            HahaStatus s;
            fixed (byte* p = &MemoryMarshal.GetReference(data))
                s = Native.haha_avatar_load_memory(data.IsEmpty ? null : p, (UIntPtr)data.Length, Native.Utf8z(name),
                                                   Native.Utf8z(bodyModelPath), out h);
            return Wrap(s, h, "haha_avatar_load_memory");
        }

        /// <summary>Loads only the importance tiers within maxGaussians (haha pack --lod);
        /// maxGaussians &lt;= 0 or a file without tiers: every Gaussian.</summary>
        public static Avatar LoadLod(string path, int maxGaussians, string bodyModelPath = null)
        {
            AvatarHandle h;
            HahaStatus s = Native.haha_avatar_load_lod(Native.Utf8z(path), Native.Utf8z(bodyModelPath), maxGaussians, out h);
            return Wrap(s, h, "haha_avatar_load_lod");
        }

        /// <summary>haha_avatar_get_info (Info holds the same).</summary>
        public AvatarInfo GetInfo()
        {
            AvatarInfo info;
            Native.Check(Native.haha_avatar_get_info(Live, out info), "haha_avatar_get_info");
            return info;
        }

        /// <summary>Triangle vertex indices, F x 3 (counter-clockwise seen from outside).</summary>
        public unsafe void GetFaces(Span<uint> indices)
        {
            fixed (uint* p = &MemoryMarshal.GetReference(indices))
                Native.Check(Native.haha_avatar_faces(Live, p, (UIntPtr)indices.Length), "haha_avatar_faces");
        }

        public uint[] GetFaces()
        {
            var a = new uint[3 * (long)Info.NumFaces];
            GetFaces(a);
            return a;
        }

        /// <summary>Texture coordinates per face corner, F x 3 x (u, v); v up (v = 1: top row).</summary>
        public unsafe void GetFaceUvs(Span<float> uvs)
        {
            fixed (float* p = &MemoryMarshal.GetReference(uvs))
                Native.Check(Native.haha_avatar_face_uvs(Live, p, (UIntPtr)uvs.Length), "haha_avatar_face_uvs");
        }

        public float[] GetFaceUvs()
        {
            var a = new float[6 * (long)Info.NumFaces];
            GetFaceUvs(a);
            return a;
        }

        /// <summary>The texture, 8-bit RGB, H x W x 3, top row first.</summary>
        public unsafe void GetTexture(Span<byte> rgb)
        {
            fixed (byte* p = &MemoryMarshal.GetReference(rgb))
                Native.Check(Native.haha_avatar_texture(Live, p, (UIntPtr)rgb.Length), "haha_avatar_texture");
        }

        public byte[] GetTexture()
        {
            var a = new byte[3L * Info.TextureWidth * Info.TextureHeight];
            GetTexture(a);
            return a;
        }

        /// <summary>The mesh coverage, one value in [0, 1] per body vertex (V; 1 everywhere when
        /// the file has none): draw the mesh only where the interpolation of a face's three values
        /// is >= HahaRuntime.MeshCoverageCutoff (an alpha test, in the depth pass too). An empty
        /// span only asks. Returns whether the file carries a coverage.</summary>
        public unsafe bool GetMeshCoverage(Span<float> perVertex)
        {
            int has;
            fixed (float* p = &MemoryMarshal.GetReference(perVertex))
                Native.Check(Native.haha_avatar_mesh_coverage(Live, perVertex.IsEmpty ? null : p, (UIntPtr)perVertex.Length, out has),
                             "haha_avatar_mesh_coverage");
            return has != 0;
        }

        public float[] GetMeshCoverage()
        {
            var a = new float[Info.NumVertices];
            GetMeshCoverage(a);
            return a;
        }

        /// <summary>Whether the file carries a mesh coverage (the mesh is cut where it is low).</summary>
        public bool HasMeshCoverage { get { return GetMeshCoverage(Span<float>.Empty); } }

        /// <summary>A new pose state (haha_posed_create): keep one per character.</summary>
        public Posed CreatePosed()
        {
            return new Posed(this);
        }

        /// <summary>Frees the avatar; the native free waits for its Posed objects.</summary>
        /// <summary>Frees the native object (idempotent); later calls throw ObjectDisposedException.</summary>
        public void Dispose()
        {
            disposed = true;
            Handle.Dispose();
        }

        bool disposed;

        /// <summary>Handle, or ObjectDisposedException after Dispose (a SafeHandle with
        /// outstanding references, as an avatar's with live pose states, stays usable).</summary>
        internal AvatarHandle Live
        {
            get
            {
                if (disposed) throw new ObjectDisposedException(GetType().FullName);
                return Handle;
            }
        }
    }

    /// <summary>One pose state of an avatar with its render scratch (haha_posed): one thread
    /// at a time; make one per character / thread.</summary>
    public sealed class Posed : IDisposable
    {
        public PosedHandle Handle { get; }
        public Avatar Avatar { get; }
        public int NumVertices { get { return Avatar.Info.NumVertices; } }
        public int NumGaussians { get { return Avatar.Info.NumGaussians; } }

        internal Posed(Avatar avatar)
        {
            Avatar = avatar;
            AvatarHandle a = avatar.Live;
            bool added = false;
            PosedHandle h = null;
            try
            {
                a.DangerousAddRef(ref added);  // released by the PosedHandle's ReleaseHandle
                HahaStatus s = Native.haha_posed_create(a, out h);
                if (s != HahaStatus.Ok)
                {
                    string message = HahaRuntime.LastError;
                    if (h != null) h.Dispose();
                    throw new HahaException(s, "haha_posed_create", message);
                }
                h.avatar = a;
                added = false;  // owned by h now
                Handle = h;
            }
            finally
            {
                if (added) a.DangerousRelease();
            }
        }

        /// <summary>Poses the avatar: pose is 165 axis-angle floats (SMPL-X joint order) or
        /// empty / null for the rest pose; translation 3 floats or empty / null for none.</summary>
        public void Repose(ReadOnlySpan<float> pose, ReadOnlySpan<float> translation)
        {
            Repose(pose, translation, ReadOnlySpan<float>.Empty, ReadOnlySpan<float>.Empty);
        }

        /// <summary>haha_repose in full. A packed avatar's shape is baked: non-empty betas or
        /// expression is HahaStatus.ErrorArgument (kept for a future file version).</summary>
        public unsafe void Repose(ReadOnlySpan<float> pose, ReadOnlySpan<float> translation, ReadOnlySpan<float> betas,
                                  ReadOnlySpan<float> expression)
        {
            if (!pose.IsEmpty && pose.Length != HahaRuntime.NumPoseValues)
                throw new ArgumentException("Repose: pose needs " + HahaRuntime.NumPoseValues + " floats, got " + pose.Length);
            if (!translation.IsEmpty && translation.Length != 3)
                throw new ArgumentException("Repose: translation needs 3 floats, got " + translation.Length);
            fixed (float* p = &MemoryMarshal.GetReference(pose))
            fixed (float* t = &MemoryMarshal.GetReference(translation))
            fixed (float* b = &MemoryMarshal.GetReference(betas))
            fixed (float* e = &MemoryMarshal.GetReference(expression))
                Native.Check(Native.haha_repose(Live, pose.IsEmpty ? null : p, translation.IsEmpty ? null : t,
                                                betas.IsEmpty ? null : b, (UIntPtr)betas.Length,
                                                expression.IsEmpty ? null : e, (UIntPtr)expression.Length),
                             "haha_repose");
        }

        /// <summary>Posed body vertices, V x 3, world space, in the faces' vertex order.</summary>
        public unsafe void GetVertices(Span<float> xyz)
        {
            fixed (float* p = &MemoryMarshal.GetReference(xyz))
                Native.Check(Native.haha_posed_vertices(Live, p, (UIntPtr)xyz.Length), "haha_posed_vertices");
        }

        public float[] GetVertices()
        {
            var a = new float[3 * (long)NumVertices];
            GetVertices(a);
            return a;
        }

        /// <summary>Unit area-weighted vertex normals of the posed mesh, V x 3.</summary>
        public unsafe void GetNormals(Span<float> xyz)
        {
            fixed (float* p = &MemoryMarshal.GetReference(xyz))
                Native.Check(Native.haha_posed_normals(Live, p, (UIntPtr)xyz.Length), "haha_posed_normals");
        }

        public float[] GetNormals()
        {
            var a = new float[3 * (long)NumVertices];
            GetNormals(a);
            return a;
        }

        /// <summary>Posed joint positions, 55 x 3, world space.</summary>
        public unsafe void GetJoints(Span<float> xyz)
        {
            fixed (float* p = &MemoryMarshal.GetReference(xyz))
                Native.Check(Native.haha_posed_joints(Live, p, (UIntPtr)xyz.Length), "haha_posed_joints");
        }

        public float[] GetJoints()
        {
            var a = new float[3 * HahaRuntime.NumJoints];
            GetJoints(a);
            return a;
        }

        /// <summary>Copies the posed Gaussians (haha_posed_gaussians). An empty span skips
        /// that array; the others hold at least N Gaussians each (means 3N, rotations 4N
        /// (w, x, y, z), scales 3N, colors 3N, opacities N), else ErrorArgument.</summary>
        public unsafe void GetGaussians(Span<float> means, Span<float> rotations, Span<float> scales, Span<float> colors,
                                        Span<float> opacities)
        {
            // The capacity the C call checks: the Gaussians the smallest non-empty span holds.
            long capacity = long.MaxValue;
            if (!means.IsEmpty) capacity = Math.Min(capacity, means.Length / 3);
            if (!rotations.IsEmpty) capacity = Math.Min(capacity, rotations.Length / 4);
            if (!scales.IsEmpty) capacity = Math.Min(capacity, scales.Length / 3);
            if (!colors.IsEmpty) capacity = Math.Min(capacity, colors.Length / 3);
            if (!opacities.IsEmpty) capacity = Math.Min(capacity, opacities.Length);
            if (capacity == long.MaxValue) capacity = 0;
            fixed (float* m = &MemoryMarshal.GetReference(means))
            fixed (float* r = &MemoryMarshal.GetReference(rotations))
            fixed (float* s = &MemoryMarshal.GetReference(scales))
            fixed (float* c = &MemoryMarshal.GetReference(colors))
            fixed (float* o = &MemoryMarshal.GetReference(opacities))
            {
                var arrays = new Native.haha_gaussian_arrays
                {
                    capacity = (UIntPtr)capacity,
                    means = means.IsEmpty ? null : m,
                    rotations = rotations.IsEmpty ? null : r,
                    scales = scales.IsEmpty ? null : s,
                    colors = colors.IsEmpty ? null : c,
                    opacities = opacities.IsEmpty ? null : o,
                };
                Native.Check(Native.haha_posed_gaussians(Live, ref arrays), "haha_posed_gaussians");
            }
        }

        /// <summary>Copies all five arrays into buffers made with GaussianBuffers(NumGaussians).</summary>
        public void GetGaussians(GaussianBuffers g)
        {
            GetGaussians(g.Means, g.Rotations, g.Scales, g.Colors, g.Opacities);
        }

        public GaussianBuffers GetGaussians()
        {
            var g = new GaussianBuffers(NumGaussians);
            GetGaussians(g);
            return g;
        }

        /// <summary>Renders the last repose with the built-in merged renderer into 8-bit
        /// pixels (Rgb8 / Rgba8): Height rows of Width pixels, top row first.
        /// background: 3 floats in [0, 1] or null (black).</summary>
        public unsafe void Render(Camera camera, Span<byte> pixels, PixelFormat format = PixelFormat.Rgb8,
                                  float[] background = null, RenderFlags flags = RenderFlags.None)
        {
            fixed (byte* p = &MemoryMarshal.GetReference(pixels))
                Render(camera, p, (long)pixels.Length, format, background, flags);
        }

        /// <summary>The same into float pixels (Rgb32F / Rgba32F, the renderer's unclamped values).</summary>
        public unsafe void Render(Camera camera, Span<float> pixels, PixelFormat format, float[] background = null,
                                  RenderFlags flags = RenderFlags.None)
        {
            fixed (float* p = &MemoryMarshal.GetReference(pixels))
                Render(camera, p, 4L * pixels.Length, format, background, flags);
        }

        unsafe void Render(Camera camera, void* pixels, long capacityBytes, PixelFormat format, float[] background,
                           RenderFlags flags)
        {
            if (camera == null) throw new ArgumentNullException("camera");
            if (background != null && background.Length != 3)
                throw new ArgumentException("Render: background needs 3 floats, got " + background.Length);
            Native.haha_camera c = camera.ToNative();
            fixed (float* bg = background)
                Native.Check(Native.haha_render(Live, ref c, bg, (uint)flags, format, pixels, (UIntPtr)capacityBytes),
                             "haha_render");
        }

        /// <summary>Frees the native object (idempotent); later calls throw ObjectDisposedException.</summary>
        public void Dispose()
        {
            disposed = true;
            Handle.Dispose();
        }

        bool disposed;

        /// <summary>Handle, or ObjectDisposedException after Dispose (a SafeHandle with
        /// outstanding references, as an avatar's with live pose states, stays usable).</summary>
        internal PosedHandle Live
        {
            get
            {
                if (disposed) throw new ObjectDisposedException(GetType().FullName);
                return Handle;
            }
        }
    }

    /// <summary>A loaded motion (haha_motion): immutable, shareable between threads.</summary>
    public sealed class Motion : IDisposable
    {
        public MotionHandle Handle { get; }
        public int NumFrames { get; }
        public double Fps { get; }

        Motion(HahaStatus status, MotionHandle handle, string call)
        {
            if (status != HahaStatus.Ok)
            {
                string message = HahaRuntime.LastError;
                if (handle != null) handle.Dispose();
                throw new HahaException(status, call, message);
            }
            Handle = handle;
            int frames;
            double fps;
            Native.Check(Native.haha_motion_info(handle, out frames, out fps), "haha_motion_info");
            NumFrames = frames;
            Fps = fps;
        }

        /// <summary>Reads a motion .npz (AMASS SMPL-X / SMPL+H, native SMPL-X parameters) as stored.</summary>
        public static Motion Load(string path)
        {
            MotionHandle h;
            HahaStatus s = Native.haha_motion_load(Native.Utf8z(path), out h);
            return new Motion(s, h, "haha_motion_load");
        }

        /// <summary>As Load, for posing avatar: an AMASS (Z-up) motion is turned upright about
        /// the avatar's rest pelvis. The motion does not keep the avatar.</summary>
        public static Motion LoadForAvatar(string path, Avatar avatar)
        {
            if (avatar == null) throw new ArgumentNullException("avatar");
            MotionHandle h;
            HahaStatus s = Native.haha_motion_load_for_avatar(Native.Utf8z(path), avatar.Live, out h);
            return new Motion(s, h, "haha_motion_load_for_avatar");
        }

        /// <summary>One frame (0 .. NumFrames-1): pose 165 floats and translation 3 floats;
        /// an empty span skips that part.</summary>
        public unsafe void GetFrame(int frame, Span<float> pose, Span<float> translation)
        {
            if (!pose.IsEmpty && pose.Length != HahaRuntime.NumPoseValues)
                throw new ArgumentException("GetFrame: pose needs " + HahaRuntime.NumPoseValues + " floats, got " + pose.Length);
            if (!translation.IsEmpty && translation.Length != 3)
                throw new ArgumentException("GetFrame: translation needs 3 floats, got " + translation.Length);
            fixed (float* p = &MemoryMarshal.GetReference(pose))
            fixed (float* t = &MemoryMarshal.GetReference(translation))
                Native.Check(Native.haha_motion_frame(Live, frame, pose.IsEmpty ? null : p, translation.IsEmpty ? null : t),
                             "haha_motion_frame");
        }

        /// <summary>Frees the native object (idempotent); later calls throw ObjectDisposedException.</summary>
        public void Dispose()
        {
            disposed = true;
            Handle.Dispose();
        }

        bool disposed;

        /// <summary>Handle, or ObjectDisposedException after Dispose (a SafeHandle with
        /// outstanding references, as an avatar's with live pose states, stays usable).</summary>
        internal MotionHandle Live
        {
            get
            {
                if (disposed) throw new ObjectDisposedException(GetType().FullName);
                return Handle;
            }
        }
    }

    /// <summary>haha_avatar*: haha_avatar_free on release.</summary>
    public sealed class AvatarHandle : SafeHandleZeroOrMinusOneIsInvalid
    {
        AvatarHandle() : base(true) { }  // made by the marshaller for "out" parameters

        protected override bool ReleaseHandle()
        {
            Native.haha_avatar_free(handle);
            return true;
        }
    }

    /// <summary>haha_posed*: haha_posed_free on release, then releases its avatar's handle.</summary>
    public sealed class PosedHandle : SafeHandleZeroOrMinusOneIsInvalid
    {
        internal AvatarHandle avatar;  // DangerousAddRef'd while this handle lives

        PosedHandle() : base(true) { }

        protected override bool ReleaseHandle()
        {
            Native.haha_posed_free(handle);
            if (avatar != null) avatar.DangerousRelease();  // may free the avatar now
            return true;
        }
    }

    /// <summary>haha_motion*: haha_motion_free on release.</summary>
    public sealed class MotionHandle : SafeHandleZeroOrMinusOneIsInvalid
    {
        MotionHandle() : base(true) { }

        protected override bool ReleaseHandle()
        {
            Native.haha_motion_free(handle);
            return true;
        }
    }

    /// <summary>The C functions as declared in haha_runtime.h (size_t: UIntPtr; char*: a
    /// NUL-terminated UTF-8 byte[], see Utf8z). Handles are SafeHandles: the marshaller
    /// keeps them alive and undisposed for the length of a call.</summary>
    public static unsafe class Native
    {
        /// <summary>libhaha_runtime.so on Linux (lib prefix and .so added by the loader);
        /// "__Internal" for statically linked IL2CPP targets.</summary>
        public const string LibraryName = "haha_runtime";
        const CallingConvention Cdecl = CallingConvention.Cdecl;

        [StructLayout(LayoutKind.Sequential)]
        public struct haha_camera
        {
            public int width, height;
            public float fx, fy, cx, cy;
            public fixed float rotation[9];
            public fixed float translation[3];
            public float near_plane, far_plane;
        }

        [StructLayout(LayoutKind.Sequential)]
        public struct haha_gaussian_arrays
        {
            public UIntPtr capacity;
            public float* means;
            public float* rotations;
            public float* scales;
            public float* colors;
            public float* opacities;
        }

        [DllImport(LibraryName, CallingConvention = Cdecl)]
        public static extern HahaStatus haha_version(out int major, out int minor, out int patch);
        [DllImport(LibraryName, CallingConvention = Cdecl)]
        public static extern IntPtr haha_version_string();
        [DllImport(LibraryName, CallingConvention = Cdecl)]
        public static extern IntPtr haha_last_error();
        [DllImport(LibraryName, CallingConvention = Cdecl)]
        public static extern IntPtr haha_status_string(HahaStatus status);
        [DllImport(LibraryName, CallingConvention = Cdecl)]
        public static extern HahaStatus haha_set_num_threads(int n);

        [DllImport(LibraryName, CallingConvention = Cdecl)]
        public static extern HahaStatus haha_avatar_load(byte[] path, byte[] bodyModelPath, out AvatarHandle avatar);
        [DllImport(LibraryName, CallingConvention = Cdecl)]
        public static extern HahaStatus haha_avatar_load_memory(void* data, UIntPtr size, byte[] name, byte[] bodyModelPath,
                                                                out AvatarHandle avatar);
        [DllImport(LibraryName, CallingConvention = Cdecl)]
        public static extern HahaStatus haha_avatar_load_lod(byte[] path, byte[] bodyModelPath, int maxGaussians,
                                                             out AvatarHandle avatar);
        [DllImport(LibraryName, CallingConvention = Cdecl)]
        public static extern void haha_avatar_free(IntPtr avatar);
        [DllImport(LibraryName, CallingConvention = Cdecl)]
        public static extern HahaStatus haha_avatar_get_info(AvatarHandle avatar, out AvatarInfo info);
        [DllImport(LibraryName, CallingConvention = Cdecl)]
        public static extern HahaStatus haha_avatar_faces(AvatarHandle avatar, uint* indices, UIntPtr capacity);
        [DllImport(LibraryName, CallingConvention = Cdecl)]
        public static extern HahaStatus haha_avatar_face_uvs(AvatarHandle avatar, float* uvs, UIntPtr capacity);
        [DllImport(LibraryName, CallingConvention = Cdecl)]
        public static extern HahaStatus haha_avatar_texture(AvatarHandle avatar, byte* rgb, UIntPtr capacity);
        [DllImport(LibraryName, CallingConvention = Cdecl)]
        public static extern HahaStatus haha_avatar_mesh_coverage(AvatarHandle avatar, float* perVertex, UIntPtr capacity, out int hasCoverage);

        [DllImport(LibraryName, CallingConvention = Cdecl)]
        public static extern HahaStatus haha_posed_create(AvatarHandle avatar, out PosedHandle posed);
        [DllImport(LibraryName, CallingConvention = Cdecl)]
        public static extern void haha_posed_free(IntPtr posed);
        [DllImport(LibraryName, CallingConvention = Cdecl)]
        public static extern HahaStatus haha_repose(PosedHandle posed, float* pose, float* translation, float* betas,
                                                    UIntPtr numBetas, float* expression, UIntPtr numExpression);
        [DllImport(LibraryName, CallingConvention = Cdecl)]
        public static extern HahaStatus haha_posed_vertices(PosedHandle posed, float* xyz, UIntPtr capacity);
        [DllImport(LibraryName, CallingConvention = Cdecl)]
        public static extern HahaStatus haha_posed_normals(PosedHandle posed, float* xyz, UIntPtr capacity);
        [DllImport(LibraryName, CallingConvention = Cdecl)]
        public static extern HahaStatus haha_posed_joints(PosedHandle posed, float* xyz, UIntPtr capacity);
        [DllImport(LibraryName, CallingConvention = Cdecl)]
        public static extern HahaStatus haha_posed_gaussians(PosedHandle posed, ref haha_gaussian_arrays arrays);

        [DllImport(LibraryName, CallingConvention = Cdecl)]
        public static extern HahaStatus haha_render(PosedHandle posed, ref haha_camera camera, float* background, uint flags,
                                                    PixelFormat format, void* pixels, UIntPtr capacityBytes);

        [DllImport(LibraryName, CallingConvention = Cdecl)]
        public static extern HahaStatus haha_motion_load(byte[] path, out MotionHandle motion);
        [DllImport(LibraryName, CallingConvention = Cdecl)]
        public static extern HahaStatus haha_motion_load_for_avatar(byte[] path, AvatarHandle avatar, out MotionHandle motion);
        [DllImport(LibraryName, CallingConvention = Cdecl)]
        public static extern void haha_motion_free(IntPtr motion);
        [DllImport(LibraryName, CallingConvention = Cdecl)]
        public static extern HahaStatus haha_motion_info(MotionHandle motion, out int numFrames, out double fps);
        [DllImport(LibraryName, CallingConvention = Cdecl)]
        public static extern HahaStatus haha_motion_frame(MotionHandle motion, int frame, float* pose, float* translation);

        [DllImport(LibraryName, CallingConvention = Cdecl)]
        public static extern HahaStatus haha_write_png(byte[] path, int width, int height, int channels, byte* pixels);

        /// <summary>A NUL-terminated UTF-8 copy of s; null for null (the C API's NULL).</summary>
        public static byte[] Utf8z(string s)
        {
            if (s == null) return null;
            var bytes = new byte[Encoding.UTF8.GetByteCount(s) + 1];
            Encoding.UTF8.GetBytes(s, 0, s.Length, bytes, 0);
            return bytes;
        }

        /// <summary>A library-owned NUL-terminated UTF-8 string as a string ("" for NULL).</summary>
        public static string Utf8String(IntPtr p)
        {
            if (p == IntPtr.Zero) return "";
            byte* b = (byte*)p;
            int n = 0;
            while (b[n] != 0) ++n;
            return Encoding.UTF8.GetString(b, n);
        }

        /// <summary>Throws a HahaException for a failed status, with this thread's last error.</summary>
        public static void Check(HahaStatus status, string call)
        {
            if (status != HahaStatus.Ok) throw new HahaException(status, call, HahaRuntime.LastError);
        }
    }
}
