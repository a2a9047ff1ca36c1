#include "sim/embree_device.h"

#include <mutex>
#include <utility>

#include <fmt/format.h>

#include "common/error.h"

namespace plumage::sim {

struct EmbreeDevice::ErrorLog {
    std::mutex mutex;
    bool pending = false;
    RTCError code = RTC_ERROR_NONE;
    std::string message;
};

namespace {

const char* error_name(RTCError code) {
    switch (code) {
        case RTC_ERROR_NONE:
            return "none";
        case RTC_ERROR_UNKNOWN:
            return "unknown";
        case RTC_ERROR_INVALID_ARGUMENT:
            return "invalid argument";
        case RTC_ERROR_INVALID_OPERATION:
            return "invalid operation";
        case RTC_ERROR_OUT_OF_MEMORY:
            return "out of memory";
        case RTC_ERROR_UNSUPPORTED_CPU:
            return "unsupported CPU";
        case RTC_ERROR_CANCELLED:
            return "cancelled";
    }
    return "unrecognised";
}

// Called by Embree inside its C API: record, never throw.
void record_error(void* user, RTCError code, const char* message) {
    auto* log = static_cast<EmbreeDevice::ErrorLog*>(user);
    std::lock_guard lock(log->mutex);
    if (log->pending) return;  // keep the first: later ones are usually its consequences
    log->pending = true;
    log->code = code;
    log->message = message != nullptr ? message : "";
}

[[noreturn]] void throw_embree(RTCError code, const std::string& message, const char* what) {
    const std::string text =
        fmt::format("Embree error in {}: {} ({})", what, error_name(code), message);
    if (code == RTC_ERROR_INVALID_ARGUMENT || code == RTC_ERROR_INVALID_OPERATION) {
        throw InvariantError(text);
    }
    throw IoError(text);
}

}  // namespace

EmbreeDevice::EmbreeDevice(const std::string& config) : errors_(std::make_unique<ErrorLog>()) {
    device_ = rtcNewDevice(config.empty() ? nullptr : config.c_str());
    if (device_ == nullptr) {
        // No device yet to hold a callback: Embree keeps the reason for the null device.
        const RTCError code = rtcGetDeviceError(nullptr);
        throw IoError(fmt::format("Embree could not create a device (config \"{}\"): {}", config,
                                  error_name(code)));
    }
    rtcSetDeviceErrorFunction(device_, record_error, errors_.get());
}

EmbreeDevice::~EmbreeDevice() {
    if (device_ != nullptr) rtcReleaseDevice(device_);
}

EmbreeDevice::EmbreeDevice(EmbreeDevice&& other) noexcept
    : device_(std::exchange(other.device_, nullptr)), errors_(std::move(other.errors_)) {}

EmbreeDevice& EmbreeDevice::operator=(EmbreeDevice&& other) noexcept {
    if (this != &other) {
        if (device_ != nullptr) rtcReleaseDevice(device_);
        device_ = std::exchange(other.device_, nullptr);
        errors_ = std::move(other.errors_);
    }
    return *this;
}

void EmbreeDevice::check(const char* what) const {
    PLUMAGE_CHECK(device_ != nullptr, "check() on a moved-from Embree device");
    RTCError code = RTC_ERROR_NONE;
    std::string message;
    {
        std::lock_guard lock(errors_->mutex);
        if (errors_->pending) {
            code = errors_->code;
            message = std::move(errors_->message);
            errors_->pending = false;
        }
    }
    // Clear Embree's own per-thread error code too, so a later check does not see it.
    const RTCError sticky = rtcGetDeviceError(device_);
    if (code == RTC_ERROR_NONE) code = sticky;
    if (code != RTC_ERROR_NONE) throw_embree(code, message, what);
}

std::shared_ptr<const EmbreeDevice> default_embree_device() {
    static const std::shared_ptr<const EmbreeDevice> device = std::make_shared<EmbreeDevice>();
    return device;
}

EmbreeScene::EmbreeScene(const EmbreeDevice& device, RTCSceneFlags flags, RTCBuildQuality quality) {
    scene_ = rtcNewScene(device.get());
    if (scene_ == nullptr) device.check("rtcNewScene");
    PLUMAGE_CHECK(scene_ != nullptr, "rtcNewScene returned null without an error");
    rtcSetSceneFlags(scene_, flags);
    rtcSetSceneBuildQuality(scene_, quality);
    device.check("rtcSetSceneFlags / rtcSetSceneBuildQuality");
}

EmbreeScene::~EmbreeScene() {
    if (scene_ != nullptr) rtcReleaseScene(scene_);
}

EmbreeScene::EmbreeScene(EmbreeScene&& other) noexcept
    : scene_(std::exchange(other.scene_, nullptr)) {}

EmbreeScene& EmbreeScene::operator=(EmbreeScene&& other) noexcept {
    if (this != &other) {
        if (scene_ != nullptr) rtcReleaseScene(scene_);
        scene_ = std::exchange(other.scene_, nullptr);
    }
    return *this;
}

void EmbreeScene::commit(const EmbreeDevice& device) {
    rtcCommitScene(scene_);
    device.check("rtcCommitScene");
}

EmbreeGeometry::EmbreeGeometry(const EmbreeDevice& device, RTCGeometryType type) {
    geometry_ = rtcNewGeometry(device.get(), type);
    if (geometry_ == nullptr) device.check("rtcNewGeometry");
    PLUMAGE_CHECK(geometry_ != nullptr, "rtcNewGeometry returned null without an error");
}

EmbreeGeometry::~EmbreeGeometry() {
    if (geometry_ != nullptr) rtcReleaseGeometry(geometry_);
}

EmbreeGeometry::EmbreeGeometry(EmbreeGeometry&& other) noexcept
    : geometry_(std::exchange(other.geometry_, nullptr)) {}

EmbreeGeometry& EmbreeGeometry::operator=(EmbreeGeometry&& other) noexcept {
    if (this != &other) {
        if (geometry_ != nullptr) rtcReleaseGeometry(geometry_);
        geometry_ = std::exchange(other.geometry_, nullptr);
    }
    return *this;
}

unsigned EmbreeGeometry::commit_and_attach(const EmbreeDevice& device, const EmbreeScene& scene) {
    rtcCommitGeometry(geometry_);
    device.check("rtcCommitGeometry");
    const unsigned id = rtcAttachGeometry(scene.get(), geometry_);
    device.check("rtcAttachGeometry");
    return id;
}

std::vector<float> padded_vertex_buffer(const std::vector<float>& xyz) {
    PLUMAGE_CHECK(xyz.size() % 3 == 0, "vertex buffer of xyz triples");
    std::vector<float> padded;
    padded.reserve(xyz.size() + 1);
    padded.insert(padded.end(), xyz.begin(), xyz.end());
    padded.push_back(0.0f);
    return padded;
}

}  // namespace plumage::sim
