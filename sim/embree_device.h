// RAII ownership of Embree 3 handles (the pattern of Embree's tutorials/minimal).
//
//  - EmbreeDevice registers its error callback at creation, before any other call, so no
//    Embree error goes unseen. The callback does not throw (it runs inside Embree's C
//    API); it records the error, and check() turns it into an exception after the call:
//      invalid argument / invalid operation → InvariantError (our use of Embree is wrong)
//      out of memory, unsupported CPU, cancelled, unknown → IoError (the system refused)
//  - Geometries follow commit → attach → release: EmbreeGeometry::commit_and_attach()
//    commits, attaches (the scene takes its own reference) and the handle's destructor
//    releases ours.
//  - Vertex buffers that we share with Embree are padded by one float: Embree reads the
//    last vertex with a 16-byte SSE load (rtcSetSharedGeometryBuffer's documentation).
//    padded_vertex_buffer() builds such a buffer.
//
// Every wrapper is move-only; moved-from wrappers own nothing.
#pragma once

#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <embree3/rtcore.h>
#include <Eigen/Core>

namespace plumage::sim {

class EmbreeDevice {
public:
    // config: Embree's device configuration string ("" = defaults). IoError if Embree
    // cannot create a device (the message carries Embree's error).
    explicit EmbreeDevice(const std::string& config = "");
    ~EmbreeDevice();
    EmbreeDevice(EmbreeDevice&& other) noexcept;
    EmbreeDevice& operator=(EmbreeDevice&& other) noexcept;
    EmbreeDevice(const EmbreeDevice&) = delete;
    EmbreeDevice& operator=(const EmbreeDevice&) = delete;

    RTCDevice get() const { return device_; }
    // Throws the first error Embree reported since the last check, naming `what` (the
    // call that was made), and clears it.
    void check(const char* what) const;

    struct ErrorLog;  // shared with the callback; stable address

private:
    RTCDevice device_ = nullptr;
    std::unique_ptr<ErrorLog> errors_;
};

// The process-wide device that scenes use unless given another. Created on first use.
std::shared_ptr<const EmbreeDevice> default_embree_device();

class EmbreeScene {
public:
    EmbreeScene(const EmbreeDevice& device, RTCSceneFlags flags, RTCBuildQuality quality);
    ~EmbreeScene();
    EmbreeScene(EmbreeScene&& other) noexcept;
    EmbreeScene& operator=(EmbreeScene&& other) noexcept;
    EmbreeScene(const EmbreeScene&) = delete;
    EmbreeScene& operator=(const EmbreeScene&) = delete;

    RTCScene get() const { return scene_; }
    void commit(const EmbreeDevice& device);

private:
    RTCScene scene_ = nullptr;
};

class EmbreeGeometry {
public:
    EmbreeGeometry(const EmbreeDevice& device, RTCGeometryType type);
    ~EmbreeGeometry();
    EmbreeGeometry(EmbreeGeometry&& other) noexcept;
    EmbreeGeometry& operator=(EmbreeGeometry&& other) noexcept;
    EmbreeGeometry(const EmbreeGeometry&) = delete;
    EmbreeGeometry& operator=(const EmbreeGeometry&) = delete;

    RTCGeometry get() const { return geometry_; }
    // Commit, attach to the scene, and return the geometry ID there. The destructor then
    // releases this handle; the scene keeps the geometry alive.
    unsigned commit_and_attach(const EmbreeDevice& device, const EmbreeScene& scene);

private:
    RTCGeometry geometry_ = nullptr;
};

// xyz triples followed by one padding float (see above).
std::vector<float> padded_vertex_buffer(const std::vector<float>& xyz);

// A ray–hit record for rtcIntersect1 from a double-precision ray: origin and direction
// rounded to float, tnear 0, tfar ∞, no hit yet. The tracer and the bare-Embree baseline
// of bench/tracer_bench.cpp start from the same record, so the benchmark compares like
// with like.
inline RTCRayHit make_ray_hit(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction) {
    RTCRayHit rh{};
    rh.ray.org_x = static_cast<float>(origin.x());
    rh.ray.org_y = static_cast<float>(origin.y());
    rh.ray.org_z = static_cast<float>(origin.z());
    rh.ray.dir_x = static_cast<float>(direction.x());
    rh.ray.dir_y = static_cast<float>(direction.y());
    rh.ray.dir_z = static_cast<float>(direction.z());
    rh.ray.tnear = 0.0f;
    rh.ray.tfar = std::numeric_limits<float>::infinity();
    rh.ray.time = 0.0f;
    rh.ray.mask = 0xFFFFFFFFu;
    rh.ray.id = 0;
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    return rh;
}

}  // namespace plumage::sim
