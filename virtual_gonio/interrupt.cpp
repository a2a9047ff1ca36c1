#include "virtual_gonio/interrupt.h"

#include <csignal>

namespace plumage::gonio {
namespace {

std::atomic<bool> g_interrupted{false};
std::atomic<int> g_signal{0};
struct sigaction g_previous_int, g_previous_term;

void on_signal(int signal) {
    g_interrupted.store(true);
    g_signal.store(signal);
}

}  // namespace

ScopedInterruptHandler::ScopedInterruptHandler() {
    g_interrupted.store(false);
    g_signal.store(0);
    struct sigaction action {};
    action.sa_handler = on_signal;
    sigemptyset(&action.sa_mask);
    sigaction(SIGINT, &action, &g_previous_int);
    sigaction(SIGTERM, &action, &g_previous_term);
}

ScopedInterruptHandler::~ScopedInterruptHandler() {
    sigaction(SIGINT, &g_previous_int, nullptr);
    sigaction(SIGTERM, &g_previous_term, nullptr);
}

const std::atomic<bool>& ScopedInterruptHandler::flag() const { return g_interrupted; }
int ScopedInterruptHandler::signal_number() const { return g_signal.load(); }

}  // namespace plumage::gonio
