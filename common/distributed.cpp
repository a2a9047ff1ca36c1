#include "common/distributed.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <fstream>
#include <map>
#include <mutex>
#include <optional>
#include <thread>

#include <fmt/format.h>

#include "common/cpu_time.h"
#include "common/error.h"

#ifdef PLUMAGE_HAVE_MPI
#include <mpi.h>
#endif

namespace plumage {

void Bytes::append(const void* bytes, std::size_t n) {
    if (n == 0) return;
    const std::size_t at = data_.size();
    data_.resize(at + n);
    std::memcpy(data_.data() + at, bytes, n);
}

void Bytes::put_string(const std::string& s) {
    put(static_cast<std::uint64_t>(s.size()));
    append(s.data(), s.size());
}

std::string Bytes::get_string() {
    const auto n = get<std::uint64_t>();
    const char* p = take(n);
    return std::string(p, p + n);
}

const char* Bytes::take(std::size_t n) {
    PLUMAGE_CHECK(
        n <= data_.size() - read_,
        fmt::format("reading {} bytes with {} left of a chunk result", n, data_.size() - read_));
    const char* p = data_.data() + read_;
    read_ += n;
    return p;
}

namespace distributed {
namespace {

bool g_active = false;  // MPI initialised (any size)
// Inside a chunk the rank works alone: a measurement that deals its own chunks (a goniometer
// inside a dealt study point) runs them in-process, as its callers on other ranks are busy.
std::atomic<int> g_inside_chunk{0};
int g_rank = 0, g_size = 1;
int g_stderr = 2;  // the rank's original stderr

// FNV-1a: the key of a chunk checkpoint, stored in its header.
std::uint64_t fnv1a(const std::string& text) {
    std::uint64_t h = 1469598103934665603ULL;
    for (unsigned char c : text) h = (h ^ c) * 1099511628211ULL;
    return h;
}

constexpr char kMagic[16] = "plumage chunk 1";

std::filesystem::path chunk_file(const std::filesystem::path& dir, std::size_t index) {
    return dir / fmt::format("chunk-{:06d}.bin", index);
}

// Header (magic, key hash, chunk count, index, payload size), then the payload.
void write_chunk(const ChunkOptions& o, std::size_t n, std::size_t index, const Bytes& result) {
    std::filesystem::create_directories(o.checkpoint_dir);
    const auto path = chunk_file(o.checkpoint_dir, index);
    const auto temporary = path.string() + fmt::format(".tmp-{}", ::getpid());
    {
        std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
        Bytes header;
        for (char c : kMagic) header.put(c);
        header.put(fnv1a(o.checkpoint_key));
        header.put(static_cast<std::uint64_t>(n));
        header.put(static_cast<std::uint64_t>(index));
        header.put(static_cast<std::uint64_t>(result.data().size()));
        out.write(header.data().data(), static_cast<std::streamsize>(header.data().size()));
        out.write(result.data().data(), static_cast<std::streamsize>(result.data().size()));
        out.flush();
        if (!out) throw IoError(fmt::format("cannot write the checkpoint {}", temporary));
    }
    std::filesystem::rename(temporary, path);
}

// The chunk's result if its checkpoint exists and belongs to this key and chunk count; else,
// for a file that exists, why it is not used (ChunkResults::not_resumed).
std::optional<Bytes> read_chunk(const ChunkOptions& o, std::size_t n, std::size_t index,
                                std::string& why_not) {
    const auto path = chunk_file(o.checkpoint_dir, index);
    std::ifstream in(path, std::ios::binary);
    if (!in) return std::nullopt;
    std::vector<char> data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    constexpr std::size_t header_size = sizeof(kMagic) + 4 * sizeof(std::uint64_t);
    why_not = "damaged (not a whole chunk checkpoint)";
    if (data.size() < header_size) return std::nullopt;
    Bytes file(std::move(data));
    for (char c : kMagic)
        if (file.get<char>() != c) return std::nullopt;
    why_not = "made by another run (a different build, study or limits)";
    if (file.get<std::uint64_t>() != fnv1a(o.checkpoint_key)) return std::nullopt;
    why_not = "made for another number of chunks";
    if (file.get<std::uint64_t>() != n || file.get<std::uint64_t>() != index) return std::nullopt;
    const auto size = file.get<std::uint64_t>();
    why_not = "damaged (cut short)";
    if (file.data().size() != header_size + size) return std::nullopt;
    why_not.clear();
    return Bytes(std::vector<char>(file.data().begin() + header_size, file.data().end()));
}

// PLUMAGE_CHUNK_LOG=<file>: rank 0 appends one CSV line per chunk (which rank ran it, its compute
// time and result size) and one per deal_chunks call (chunk = -1: the call's wall time and the
// bytes broadcast): the measurements of scripts/mpi_scaling_model.py.
class ChunkLog {
public:
    static ChunkLog& get() {
        static ChunkLog log;
        return log;
    }
    void chunk(std::size_t index, int by_rank, double wall_s, double cpu_s, std::size_t bytes) {
        if (file_ == nullptr) return;
        std::fputs(fmt::format("{},{},{},{},{:.6f},{:.6f},{}\n", call_, chunks_, index, by_rank,
                               wall_s, cpu_s, bytes)
                       .c_str(),
                   file_);
    }
    void begin_call(std::size_t chunks) { ++call_, chunks_ = chunks; }
    void end_call(double seconds, std::size_t bytes) {
        if (file_ == nullptr) return;
        std::fputs(
            fmt::format("{},{},-1,{},{:.6f},,{}\n", call_, chunks_, g_size, seconds, bytes).c_str(),
            file_);
        std::fflush(file_);
    }

private:
    ChunkLog() {
        const char* path = std::getenv("PLUMAGE_CHUNK_LOG");
        if (path == nullptr || g_rank != 0) return;
        file_ = std::fopen(path, "a");
        if (file_ == nullptr) {
            // The log is optional and the run goes on without it, but the user asked for it:
            // say once (this is the process's one ChunkLog) why it will not appear.
            std::fputs(fmt::format("plumage: warning: PLUMAGE_CHUNK_LOG: cannot open '{}' ({}); "
                                   "no chunk log is written\n",
                                   path, std::strerror(errno))
                           .c_str(),
                       stderr);
            return;
        }
        if (std::ftell(file_) == 0)
            std::fputs("call,chunks,chunk,rank,wall_s,cpu_s,result_bytes\n", file_);
    }
    std::FILE* file_ = nullptr;
    std::size_t call_ = 0, chunks_ = 0;
};

double seconds_since(std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// A chunk's result with its wall and CPU seconds (the rank's process: all its threads).
struct Timed {
    Bytes result;
    double wall_s = 0.0, cpu_s = 0.0;
};

Timed timed(const std::function<Bytes(std::size_t)>& work, std::size_t i) {
    const auto start = std::chrono::steady_clock::now();
    const double cpu_start = process_cpu_seconds();
    ++g_inside_chunk;
    struct Leave {
        ~Leave() { --g_inside_chunk; }
    } leave;
    Bytes result = work(i);
    return {std::move(result), seconds_since(start), process_cpu_seconds() - cpu_start};
}

// What rank 0 (or the only process) keeps while chunks are dealt.
struct Ledger {
    const ChunkOptions& options;
    std::size_t n;
    std::vector<std::optional<Bytes>> results;
    std::vector<std::size_t> pending;
    std::atomic<std::size_t> next{0};
    std::atomic<bool> stopped{false};    // by an interrupt
    std::atomic<bool> abandoned{false};  // rank 0's own chunk failed: stop serving at once
    std::mutex mutex;
    std::size_t done = 0;
    std::map<std::string, std::size_t> not_resumed;  // checkpoint files not used, by reason

    Ledger(const ChunkOptions& o, std::size_t count) : options(o), n(count), results(count) {
        for (std::size_t i = 0; i < n; ++i) {
            std::string why_not;
            if (!o.checkpoint_dir.empty()) results[i] = read_chunk(o, n, i, why_not);
            if (!why_not.empty()) ++not_resumed[why_not];
            if (results[i]) {
                ++done;
            } else {
                pending.push_back(i);
            }
        }
    }
    // The next chunk to run, or none (all dealt, or interrupted).
    std::optional<std::size_t> take() {
        if (options.interrupt != nullptr && options.interrupt->load()) stopped.store(true);
        if (stopped.load()) return std::nullopt;
        const std::size_t k = next.fetch_add(1);
        if (k >= pending.size()) return std::nullopt;
        return pending[k];
    }
    void finish(std::size_t index, Timed timed_result, int by_rank) {
        Bytes& result = timed_result.result;
        const std::lock_guard lock(mutex);
        ChunkLog::get().chunk(index, by_rank, timed_result.wall_s, timed_result.cpu_s,
                              result.data().size());
        if (!options.checkpoint_dir.empty()) write_chunk(options, n, index, result);
        results[index] = std::move(result);
        ++done;
        if (options.on_chunk) options.on_chunk(done, n);
    }
};

#ifdef PLUMAGE_HAVE_MPI
constexpr int kTagResult = 1901, kTagReply = 1902;

// Waits for a request without spinning a core: MPI_Test drives progress, a short sleep
// between tests leaves the core to the OpenMP threads of a rank on the same node.
void wait_politely(MPI_Request& request) {
    for (int tests = 0;; ++tests) {
        int done = 0;
        MPI_Test(&request, &done, MPI_STATUS_IGNORE);
        if (done) return;
        if (tests > 64) std::this_thread::sleep_for(std::chrono::microseconds(100));
    }
}

int message_size(std::size_t bytes) {
    PLUMAGE_CHECK(
        bytes < (std::size_t{1} << 31),
        fmt::format("a chunk result of {} bytes: more than one MPI message holds", bytes));
    return static_cast<int>(bytes);
}

// Rank 0's service thread: answers every other rank until each has been told to stop.
void serve_workers(Ledger& ledger) {
    int stopped_ranks = 0;
    while (stopped_ranks < g_size - 1 && !ledger.abandoned.load()) {
        int arrived = 0;
        MPI_Status status;
        MPI_Iprobe(MPI_ANY_SOURCE, kTagResult, MPI_COMM_WORLD, &arrived, &status);
        if (!arrived) {
            std::this_thread::sleep_for(std::chrono::microseconds(100));
            continue;
        }
        int count = 0;
        MPI_Get_count(&status, MPI_BYTE, &count);
        std::vector<char> message(static_cast<std::size_t>(count));
        MPI_Recv(message.data(), count, MPI_BYTE, status.MPI_SOURCE, kTagResult, MPI_COMM_WORLD,
                 MPI_STATUS_IGNORE);
        std::int64_t index = -1;
        double seconds[2] = {0.0, 0.0};  // wall, CPU
        constexpr std::size_t header = sizeof index + sizeof seconds;
        std::memcpy(&index, message.data(), sizeof index);
        std::memcpy(seconds, message.data() + sizeof index, sizeof seconds);
        if (index >= 0) {
            ledger.finish(static_cast<std::size_t>(index),
                          {Bytes(std::vector<char>(message.begin() + header, message.end())),
                           seconds[0], seconds[1]},
                          status.MPI_SOURCE);
        }
        const auto next = ledger.take();
        const std::int64_t reply = next ? static_cast<std::int64_t>(*next) : -1;
        MPI_Send(&reply, 1, MPI_INT64_T, status.MPI_SOURCE, kTagReply, MPI_COMM_WORLD);
        if (reply < 0) ++stopped_ranks;
    }
}

// Another rank: sends its last result (none at first), receives the next index, until stop.
void work_for_rank0(const std::function<Bytes(std::size_t)>& work) {
    std::int64_t index = -1;
    Timed result;  // with its times, for the chunk log
    for (;;) {
        Bytes message;
        message.put(index);
        message.put(result.wall_s);
        message.put(result.cpu_s);
        message.append(result.result.data().data(), result.result.data().size());
        MPI_Request send;
        MPI_Isend(message.data().data(), message_size(message.data().size()), MPI_BYTE, 0,
                  kTagResult, MPI_COMM_WORLD, &send);
        wait_politely(send);
        std::int64_t reply = -1;
        MPI_Request receive;
        MPI_Irecv(&reply, 1, MPI_INT64_T, 0, kTagReply, MPI_COMM_WORLD, &receive);
        wait_politely(receive);
        if (reply < 0) return;
        index = reply;
        result = timed(work, static_cast<std::size_t>(index));
    }
}
#endif

// Every chunk's result in one buffer: sizes, then the results in chunk order.
Bytes pack(std::vector<std::optional<Bytes>>& results) {
    Bytes all;
    for (const auto& r : results) all.put(static_cast<std::uint64_t>(r->data().size()));
    for (const auto& r : results) all.append(r->data().data(), r->data().size());
    return all;
}

std::vector<Bytes> unpack(Bytes all, std::size_t n) {
    std::vector<std::uint64_t> sizes(n);
    for (auto& s : sizes) s = all.get<std::uint64_t>();
    std::vector<Bytes> results(n);
    std::size_t at = n * sizeof(std::uint64_t);
    for (std::size_t i = 0; i < n; ++i) {
        results[i] = Bytes(
            std::vector<char>(all.data().begin() + static_cast<std::ptrdiff_t>(at),
                              all.data().begin() + static_cast<std::ptrdiff_t>(at + sizes[i])));
        at += sizes[i];
    }
    return results;
}

}  // namespace

void init(int* argc, char*** argv) {
#ifdef PLUMAGE_HAVE_MPI
    // Only under a launcher: a plain `plumage` never starts MPI (an Open MPI singleton would
    // start a runtime daemon for nothing).
    const bool launched = std::getenv("OMPI_COMM_WORLD_SIZE") != nullptr ||
                          std::getenv("PMI_SIZE") != nullptr || std::getenv("PMIX_RANK") != nullptr;
    if (!launched) return;
    int provided = 0;
    MPI_Init_thread(argc, argv, MPI_THREAD_SERIALIZED, &provided);
    g_active = true;
    MPI_Comm_rank(MPI_COMM_WORLD, &g_rank);
    MPI_Comm_size(MPI_COMM_WORLD, &g_size);
    if (g_size > 1 && provided < MPI_THREAD_SERIALIZED) {
        abort_job(1,
                  "this MPI library does not provide MPI_THREAD_SERIALIZED, which rank 0's "
                  "dealing thread needs");
    }
#else
    (void)argc;
    (void)argv;
#endif
}

void finalize() {
#ifdef PLUMAGE_HAVE_MPI
    if (g_active) MPI_Finalize();
    g_active = false;
#endif
}

void abort_job(int code, const std::string& message) {
    print_error(g_size > 1 ? fmt::format("plumage (rank {} of {}): {}", g_rank, g_size, message)
                           : message);
#ifdef PLUMAGE_HAVE_MPI
    if (g_active) MPI_Abort(MPI_COMM_WORLD, code);
#endif
    std::_Exit(code);
}

bool active() { return g_active && g_size > 1 && g_inside_chunk.load() == 0; }
int rank() { return g_inside_chunk.load() == 0 ? g_rank : 0; }
int size() { return g_inside_chunk.load() == 0 ? g_size : 1; }
bool built_with_mpi() {
#ifdef PLUMAGE_HAVE_MPI
    return true;
#else
    return false;
#endif
}

void silence_other_ranks() {
    if (g_rank == 0) return;
    std::fflush(nullptr);
    g_stderr = ::dup(2);
    const int null = ::open("/dev/null", O_WRONLY);
    if (null >= 0) {
        ::dup2(null, 1);
        ::dup2(null, 2);
        ::close(null);
    }
}

void print_error(const std::string& message) {
    const std::string line = message + "\n";
    for (std::size_t at = 0; at < line.size();) {
        const ssize_t written = ::write(g_stderr, line.data() + at, line.size() - at);
        if (written <= 0) return;
        at += static_cast<std::size_t>(written);
    }
}

ChunkResults deal_chunks(std::size_t n, const std::function<Bytes(std::size_t)>& work,
                         const ChunkOptions& options) {
    ChunkResults out;
    const auto start = std::chrono::steady_clock::now();
    ChunkLog::get().begin_call(n);
    if (!active()) {
        Ledger ledger(options, n);
        out.resumed = ledger.done;
        out.not_resumed = ledger.not_resumed;
        while (const auto i = ledger.take()) ledger.finish(*i, timed(work, *i), 0);
        out.interrupted = ledger.stopped.load();
        if (!out.interrupted)
            for (auto& r : ledger.results) out.results.push_back(std::move(*r));
        ChunkLog::get().end_call(seconds_since(start), 0);
        return out;
    }
#ifdef PLUMAGE_HAVE_MPI
    Bytes all;
    if (g_rank == 0) {
        Ledger ledger(options, n);
        out.resumed = ledger.done;
        out.not_resumed = ledger.not_resumed;
        std::exception_ptr failure;
        std::thread dealer([&ledger] { serve_workers(ledger); });
        try {
            while (const auto i = ledger.take()) ledger.finish(*i, timed(work, *i), 0);
        } catch (...) {
            // An error or an interrupt (mpirun turns Ctrl-C into SIGTERM and soon SIGKILL): rank
            // 0 unwinds at once, removing its staging folder, and its exit ends the job.
            failure = std::current_exception();
            ledger.stopped.store(true);
            ledger.abandoned.store(true);
        }
        dealer.join();
        if (failure) std::rethrow_exception(failure);
        out.interrupted = ledger.stopped.load();
        if (!out.interrupted) all = pack(ledger.results);
    } else {
        work_for_rank0(work);
    }
    out.interrupted = broadcast_flag(out.interrupted);
    if (out.interrupted) return out;
    const std::size_t bytes = all.data().size();
    out.results = unpack(broadcast_bytes(std::move(all)), n);
    ChunkLog::get().end_call(seconds_since(start), bytes);
#endif
    return out;
}

bool run_items(std::size_t n, const std::function<void(std::size_t)>& run,
               const ItemTransport& transport, const std::atomic<bool>* interrupt,
               std::size_t blocks_per_rank) {
    const bool alone = !active();
    const std::size_t blocks =
        alone || n == 0 ? 1 : std::min(n, blocks_per_rank * static_cast<std::size_t>(size()));
    std::atomic<bool> abandoned{false};
    auto block = [&](std::size_t b) {
        const std::size_t lo = b * n / blocks, hi = (b + 1) * n / blocks;
#pragma omp parallel for schedule(dynamic, 1)
        for (std::size_t it = lo; it < hi; ++it) {
            if (abandoned.load(std::memory_order_relaxed)) continue;
            if (alone && interrupt != nullptr && interrupt->load()) {
                abandoned.store(true);
                continue;
            }
            run(it);
        }
        Bytes out;
        for (std::size_t it = lo; it < hi && !alone; ++it) transport.pack(it, out);
        return out;
    };
    ChunkOptions dealing;
    dealing.interrupt = interrupt;
    ChunkResults dealt = deal_chunks(blocks, block, dealing);
    if (abandoned.load() || dealt.interrupted) return false;
    for (std::size_t b = 0; b < blocks && !alone; ++b)
        for (std::size_t it = b * n / blocks; it < (b + 1) * n / blocks; ++it)
            transport.unpack(it, dealt.results[b]);
    return true;
}

bool broadcast_flag(bool value) {
#ifdef PLUMAGE_HAVE_MPI
    if (active()) {
        int v = value ? 1 : 0;
        MPI_Request request;
        MPI_Ibcast(&v, 1, MPI_INT, 0, MPI_COMM_WORLD, &request);
        wait_politely(request);
        return v != 0;
    }
#endif
    return value;
}

Bytes broadcast_bytes(Bytes value) {
#ifdef PLUMAGE_HAVE_MPI
    if (active()) {
        std::uint64_t size = value.data().size();
        MPI_Request request;
        MPI_Ibcast(&size, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD, &request);
        wait_politely(request);
        value.data().resize(size);
        constexpr std::uint64_t kPiece = std::uint64_t{1} << 30;
        for (std::uint64_t at = 0; at < size; at += kPiece) {
            const int count = static_cast<int>(std::min(kPiece, size - at));
            MPI_Ibcast(value.data().data() + at, count, MPI_BYTE, 0, MPI_COMM_WORLD, &request);
            wait_politely(request);
        }
        return Bytes(std::move(value.data()));
    }
#endif
    return value;
}

}  // namespace distributed
}  // namespace plumage
