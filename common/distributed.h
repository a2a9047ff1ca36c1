// Work spread over the ranks of an MPI job, for `mpirun -np N plumage ...` (issue 19).
//
// SPMD: every rank runs the same study code (geometry builds and light stages are
// deterministic, so every rank holds the same data); the heavy loops hand their independent
// chunks to deal_chunks(), which deals them dynamically over the ranks and returns every
// chunk's result, in chunk order, on every rank. The callers then reduce in their fixed order
// as before, so a result does not depend on the rank count, nor on which rank ran a chunk.
// Only rank 0 writes results (main.cpp gives the other ranks a scratch results root of their
// own, silences them and turns their plots off).
//
// Without a launcher (no OMPI_COMM_WORLD_SIZE, PMI_SIZE or PMIX_RANK in the environment), or
// in a build without MPI, MPI is never initialised: size() is 1 and deal_chunks() is a plain
// loop over the chunks in order, at no cost.
//
// Dealing: rank 0 is the dealer and a worker. A service thread on rank 0 answers the other
// ranks (each sends the result of its last chunk and receives the next index, or "stop");
// rank 0's own thread takes chunks from the same queue. A slow chunk holds up only its rank.
// The thread needs MPI_THREAD_SERIALIZED (rank 0's main thread makes no MPI call while it
// runs); waits poll with short sleeps instead of spinning, so idle ranks leave their cores to
// OpenMP threads on the same node.
//
// Checkpoints (optional): rank 0 writes each finished chunk's result to
// <checkpoint_dir>/chunk-<index>.bin (temporary name, then renamed) with the caller's key; a
// later run with the same key and chunk count loads them and deals only the others.
//
// Measurements: with PLUMAGE_CHUNK_LOG=<file> rank 0 appends a CSV line per chunk (rank, compute
// time, result bytes) and per call (wall time, bytes broadcast); scripts/mpi_scaling_model.py
// reads it.
//
// Failures: a rank that dies ends the job (Open MPI's default error handler; mpirun names the
// rank); an exception on any rank ends the job through abort_job(), which names the rank.
// An interrupt (SIGINT/SIGTERM) is taken from rank 0's flag: it stops dealing, the chunks in
// flight finish, and every rank returns interrupted = true together. If it stops rank 0's own
// chunk instead (mpirun turns Ctrl-C into SIGTERM for every rank, then SIGKILL a second later),
// rank 0 unwinds at once and ends the job; the chunks finished so far stay checkpointed.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <type_traits>
#include <vector>

namespace plumage {

// A chunk's serialised result: values appended in order and read back in the same order.
class Bytes {
public:
    Bytes() = default;
    explicit Bytes(std::vector<char> data) : data_(std::move(data)) {}

    template <class T>
    void put(const T& value) {
        static_assert(std::is_trivially_copyable_v<T>);
        append(&value, sizeof(T));
    }
    template <class T>
    void put_vector(const std::vector<T>& values) {
        static_assert(std::is_trivially_copyable_v<T>);
        put(static_cast<std::uint64_t>(values.size()));
        append(values.data(), values.size() * sizeof(T));
    }
    void put_string(const std::string& s);

    template <class T>
    T get() {
        static_assert(std::is_trivially_copyable_v<T>);
        T value;
        std::memcpy(&value, take(sizeof(T)), sizeof(T));
        return value;
    }
    template <class T>
    std::vector<T> get_vector() {
        static_assert(std::is_trivially_copyable_v<T>);
        const auto n = get<std::uint64_t>();
        std::vector<T> values(n);
        if (n > 0) std::memcpy(values.data(), take(n * sizeof(T)), n * sizeof(T));
        return values;
    }
    std::string get_string();

    const std::vector<char>& data() const { return data_; }
    std::vector<char>& data() { return data_; }

    void append(const void* bytes, std::size_t n);

private:
    const char* take(std::size_t n);  // Error when fewer than n bytes are left
    std::vector<char> data_;
    std::size_t read_ = 0;
};

namespace distributed {

// Called first in main: initialises MPI when launched by an MPI launcher (MPI build only).
void init(int* argc, char*** argv);
// Called last on success by every rank (collective); a no-op without MPI.
void finalize();
// Ends the whole job at once with `code` after printing `message` (prefixed with the rank) on
// the rank's stderr; without MPI, a plain exit. Never returns.
[[noreturn]] void abort_job(int code, const std::string& message);

// MPI initialised with more than one rank, and not inside a chunk (work called by deal_chunks):
// there every call of this header acts as in a single process.
bool active();
int rank();  // 0 without MPI, and inside a chunk
int size();  // 1 without MPI, and inside a chunk
bool built_with_mpi();

// On ranks other than 0: stdout and stderr to /dev/null, the original stderr kept for
// print_error (their progress lines would repeat rank 0's; their errors must still show).
void silence_other_ranks();
void print_error(const std::string& message);  // on the rank's original stderr, with a newline

struct ChunkOptions {
    // Polled on rank 0 between chunks; other ranks' flags are not read (rank 0 decides).
    const std::atomic<bool>* interrupt = nullptr;
    // Empty: no checkpoints. Else rank 0 keeps each finished chunk there (see above).
    std::filesystem::path checkpoint_dir;
    std::string checkpoint_key;  // what the chunks belong to: a different key is not resumed
    // Called on rank 0 after each finished chunk (from the dealing thread or the caller's),
    // never concurrently: chunks done so far (loaded ones included) and the total.
    std::function<void(std::size_t done, std::size_t total)> on_chunk;
};

struct ChunkResults {
    std::vector<Bytes> results;  // [chunk], on every rank; empty when interrupted
    bool interrupted = false;
    std::size_t resumed = 0;  // chunks loaded from checkpoints (rank 0's count; 0 elsewhere)
    // Checkpoint files found but not used, counted by why (rank 0): the caller says so, since
    // their chunks run again.
    std::map<std::string, std::size_t> not_resumed;
};

// Runs work(i) for every i in [0, n) once, somewhere in the job, and returns every result on
// every rank. work must be deterministic in i (its result may not depend on the rank).
// Collective: every rank calls it with the same n, in the same order of calls.
ChunkResults deal_chunks(std::size_t n, const std::function<Bytes(std::size_t)>& work,
                         const ChunkOptions& options = {});

// One pass of independent work items [0, n), each run once somewhere in the job, for callers
// that add the items' results up afterwards in item order on every rank (so a result depends
// on neither the thread count nor the rank count). Alone: every item runs here on all OpenMP
// threads, `interrupt` polled before each. Under MPI: the items are dealt in
// blocks_per_rank × size() contiguous blocks (deal_chunks; rank 0 polls `interrupt` between
// blocks), each block's items packed by pack(item, bytes) in item order and unpacked on every
// rank by unpack(item, bytes). run(item) may write only that item's results. False when
// interrupted: the pass is incomplete and must be discarded.
struct ItemTransport {
    std::function<void(std::size_t item, Bytes& out)> pack;
    std::function<void(std::size_t item, Bytes& in)> unpack;
};
bool run_items(std::size_t n, const std::function<void(std::size_t item)>& run,
               const ItemTransport& transport, const std::atomic<bool>* interrupt,
               std::size_t blocks_per_rank = 4);

// Rank 0's value on every rank (decisions taken from rank 0's clock or files).
bool broadcast_flag(bool value);
// Rank 0's bytes on every rank.
Bytes broadcast_bytes(Bytes value);

}  // namespace distributed
}  // namespace plumage
