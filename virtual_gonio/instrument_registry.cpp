#include "virtual_gonio/instrument_registry.h"

#include <stdexcept>
#include <vector>

#include <fmt/format.h>

namespace plumage::gonio {

double InstrumentValues::operator[](std::string_view key) const {
    const auto it = values_.find(key);
    if (it == values_.end())
        throw std::logic_error(fmt::format("instrument key '{}' was not read", key));
    return it->second;
}

// The registry: one line per instrument. X(name) takes name_instrument() from
// virtual_gonio/<name>.cpp (declared in instrument_registry.h by the same list).
std::span<const InstrumentEntry> instrument_registry() {
#define PLUMAGE_INSTRUMENT_ENTRY(name) name##_instrument(),
    static const std::vector<InstrumentEntry> entries{
        PLUMAGE_INSTRUMENTS(PLUMAGE_INSTRUMENT_ENTRY)};
#undef PLUMAGE_INSTRUMENT_ENTRY
    return entries;
}

}  // namespace plumage::gonio
