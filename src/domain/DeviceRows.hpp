#pragma once
// The ranks' halo and migration rows on a device backend (comm::RowCopier): the columns are
// device memory; an exchange's messages are packed on the device in one launch (every peer and
// column) and unpacked in another. For the MPI transport each is copied to a page-locked host
// buffer, and the received ones copied up before the unpacking, so only the rows that move cross
// the bus; for NCCL (device messages) the messages stay in device memory.
#include "comm/RowCopier.hpp"
#include "kernels/exec/DeviceBuffer.hpp"
#include "kernels/exec/RowCopy.hpp"

#include <memory>
#include <vector>

namespace kf {

class DeviceRows final : public comm::RowCopier {
public:
  /// device_messages: the messages live in device memory (a transport of device buffers).
  explicit DeviceRows(exec::Backend backend, bool device_messages = false);

protected:
  void do_gather(std::span<const comm::Column> cols, std::span<const comm::RowList> lists,
                 std::span<unsigned char* const> outs) override;
  void do_put(std::span<const comm::Column> cols, std::size_t first,
              std::span<const std::size_t> counts,
              std::span<const unsigned char* const> ins) override;
  void do_scatter(std::span<const comm::Column> cols, const comm::RowList& slots,
                  std::span<const std::size_t> counts,
                  std::span<const unsigned char* const> ins) override;
  void do_remove(std::span<const comm::Column> cols, std::size_t n,
                 std::span<const std::uint32_t> gone) override;
  std::size_t do_keep_flagged(std::span<const comm::Column> cols, std::size_t n,
                              const std::uint32_t* keep) override;
  unsigned char* do_message(std::size_t slot, std::size_t bytes) override;
  // The lists' copies mapped, filled and read on the device (a rebuild's lists never cross the
  // bus: P9, the halo's remap after each sort went through the host).
  void do_remap(comm::RowList& list, comm::Column new_of_old) override;
  comm::RowList do_remapped_range(comm::Column new_of_old, std::size_t first,
                                  std::size_t n) override;
  void do_rows_to_host(const comm::RowList& list) override;
  void do_copy_rows(const comm::RowList& list, std::uint32_t* out) override;
  comm::RowList do_adopt(const std::uint32_t* rows, std::size_t n) override;

private:
  exec::Backend backend_;
  bool device_messages_ = false;
  /// The columns as the kernels take them (a scratch list).
  const std::vector<exec::RowColumn>& columns(std::span<const comm::Column> cols);
  /// The rows flagged 1 in flags_ close up in every column, in order; returns their count.
  std::size_t compact_flagged(std::span<const comm::Column> cols);
  std::vector<exec::RowColumn> columns_;
  std::vector<exec::RowMessage> batch_;
  /// Writes the batch's messages (rows null: consecutive from first) into the rows, one launch:
  /// ins are host or device memory, as the messages are.
  void unpack(std::span<const comm::Column> cols, std::span<const std::size_t> counts,
              std::span<const unsigned char* const> ins, const std::uint32_t* rows,
              std::size_t first);
  /// A kept list's rows in device memory, uploaded at its first use.
  const std::uint32_t* device_list(const comm::RowList& list);
  /// A list of n rows held only on the device, its copy filled by `fill(dst)`.
  template <typename Fill>
  comm::RowList device_only(std::size_t n, Fill fill);
  /// The lists' device copies come from a pool and go back to it when their last RowList lets
  /// go: a rebuild's new lists take the last one's memory (cudaFree waits for the device).
  using ListBuffer = exec::DeviceBuffer<std::uint32_t>;
  struct ListPool {
    std::vector<ListBuffer> spare;
  };
  std::shared_ptr<ListBuffer> list_buffer(std::size_t n);
  std::shared_ptr<ListPool> pool_ = std::make_shared<ListPool>();
  std::vector<exec::DeviceBuffer<unsigned char>> device_messages_slots_;
  exec::DeviceBuffer<std::uint32_t> rows_, flags_, offsets_, keep_;
  exec::DeviceBuffer<unsigned char> packed_;
  /// Page-locked host messages (HaloExchange's and migrate's), kept between exchanges.
  struct Staging {
    exec::Backend backend;
    void* p = nullptr;
    std::size_t bytes = 0;
    explicit Staging(exec::Backend b) : backend(b) {}
    Staging(Staging&& o) noexcept : backend(o.backend), p(o.p), bytes(o.bytes) { o.p = nullptr; }
    Staging(const Staging&) = delete;
    ~Staging() { exec::free_host_staging(backend, p); }
  };
  std::vector<Staging> messages_;
};

/// The copier for a backend's buffers: the host's memcpy on the CPU (comm's, which cannot launch
/// kernels), DeviceRows on a device, its messages in device memory for a transport of device
/// buffers.
std::unique_ptr<comm::RowCopier> make_rows(exec::Backend backend, bool device_messages = false);

} // namespace kf
