// Paths removed on SIGTERM/SIGINT/SIGHUP (io/signal_cleanup.h), on io_internal's handler.
#include "io/signal_cleanup.h"

#include "io/io_internal.h"

namespace authalic::io {

RemovedOnSignal::RemovedOnSignal(const std::string& path, Kind kind)
    : impl_(std::make_unique<detail::RemoveOnSignal>(path, kind == Kind::File            ? detail::SignalRemoval::File
                                                           : kind == Kind::FolderOfFiles ? detail::SignalRemoval::FolderOfFiles
                                                                                         : detail::SignalRemoval::FolderIfEmpty)) {}

RemovedOnSignal::~RemovedOnSignal() = default;

}  // namespace authalic::io
