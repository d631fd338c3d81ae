// SimulationT<T>'s snapshot frame (owned rows only on N ranks) and restart from one written on
// any rank count, with the grids and lists as the writing run held them.
#include "domain/SimulationT.hpp"

#include "comm/ByteExchange.hpp"

namespace kf {

namespace {

/// Restart state of a grid kept over steps (SkinWatch::State) in a snapshot: its sorted
/// positions as the field `name`_sorted_position of phase p, its device record and host bound as
/// the scalars `name`_moved2 and `name`_bound.
template <typename T>
void put_watch(io::Frame& fr, io::Phase& p, const std::string& name,
               const typename SkinWatch<T>::State& s, bool split = false) {
  if (s.x0.empty() && !split)
    return; // never sorted (on N ranks a rank may hold no point: every rank writes the field)
  p.fields.push_back(io::Field::from(name + "_sorted_position", flatten(s.x0), 3));
  fr.scalars.push_back({name + "_moved2", static_cast<double>(s.moved2)});
  fr.scalars.push_back({name + "_bound", static_cast<double>(s.bound)});
}

const double* find_scalar(const io::Frame& fr, const std::string& name) {
  for (const auto& [k, v] : fr.scalars)
    if (k == name)
      return &v;
  return nullptr;
}

/// put_watch's state back; none when the snapshot lacks it (written without the grid, or by an
/// older knitflow).
template <typename T>
std::optional<typename SkinWatch<T>::State> get_watch(const io::Frame& fr, const io::Phase& p,
                                                      const std::string& name) {
  const io::Field* x0 = p.find(name + "_sorted_position");
  const double* moved2 = find_scalar(fr, name + "_moved2");
  const double* bound = find_scalar(fr, name + "_bound");
  if (!x0 || !moved2 || !bound)
    return std::nullopt;
  return typename SkinWatch<T>::State{unflatten(x0->as<T>()), static_cast<T>(*moved2),
                                      static_cast<T>(*bound)};
}

/// Keeps the rows of every field of p whose mask entry is nonzero.
void keep_rows(io::Phase& p, const std::vector<std::uint8_t>& mask) {
  for (io::Field& f : p.fields) {
    const std::size_t row = f.bytes.size() / std::max<std::size_t>(1, f.count);
    std::vector<unsigned char> kept;
    kept.reserve(f.bytes.size());
    std::size_t n = 0;
    for (std::size_t i = 0; i < f.count; ++i)
      if (mask[i]) {
        kept.insert(kept.end(), f.bytes.begin() + i * row, f.bytes.begin() + (i + 1) * row);
        ++n;
      }
    f.bytes = std::move(kept);
    f.count = n;
  }
}

/// The phase's rows in the order of its "id" field (a snapshot written by N ranks holds each
/// rank's rows in turn).
void rows_by_id(io::Phase& p) {
  const io::Field* idf = p.find("id");
  if (!idf)
    throw Error("restart: the snapshot's " + p.name + " phase has no id field");
  const auto id = idf->as<std::uint64_t>();
  std::vector<std::size_t> order(id.size());
  for (std::size_t k = 0; k < order.size(); ++k)
    order[k] = k;
  if (std::is_sorted(id.begin(), id.end()))
    return;
  std::sort(order.begin(), order.end(), [&](auto a, auto b) { return id[a] < id[b]; });
  for (io::Field& f : p.fields) {
    if (f.count != id.size())
      continue;
    const std::size_t row = f.bytes.size() / std::max<std::size_t>(1, f.count);
    std::vector<unsigned char> out(f.bytes.size());
    for (std::size_t k = 0; k < order.size(); ++k)
      std::copy_n(f.bytes.begin() + order[k] * row, row, out.begin() + k * row);
    f.bytes = std::move(out);
  }
}

/// The phase with every field that has a row a particle (as many rows as "id") replaced by
/// remake(field); the others as they are.
template <typename Remake>
io::Phase per_particle_fields(const io::Phase& p, Remake&& remake) {
  const io::Field* idf = p.find("id");
  const std::size_t n = idf ? idf->count : 0;
  io::Phase out{p.name, {}};
  for (const io::Field& f : p.fields)
    out.fields.push_back(f.count == n ? remake(f) : f);
  return out;
}

/// The rows listed (ascending) of every field with a row a particle; the others as they are.
io::Phase rows_kept(const io::Phase& p, const std::vector<std::size_t>& rows) {
  return per_particle_fields(p, [&](const io::Field& f) {
    const std::size_t row = f.bytes.size() / std::max<std::size_t>(1, f.count);
    io::Field g{f.name, f.type, f.components, rows.size(), {}};
    g.bytes.resize(rows.size() * row);
    for (std::size_t k = 0; k < rows.size(); ++k)
      std::copy_n(f.bytes.begin() + rows[k] * row, row, g.bytes.begin() + k * row);
    return g;
  });
}

/// out[k] = v[perm[k]]: a host copy put in a sort's order.
template <typename U>
std::vector<U> permuted(const std::vector<U>& v, const std::vector<std::uint32_t>& perm) {
  std::vector<U> out(perm.size());
  for (std::size_t k = 0; k < perm.size(); ++k)
    out[k] = v[perm[k]];
  return out;
}

/// A phase whose rows are this rank's share of the file's (the shares in rank order) sent to the
/// rows' owners (`owner`, one a row): every rank gets the rows it owns in the file's order, each
/// share's in its order, the shares in rank order, as rows_kept of the whole phase would keep
/// them. Fields without a row a particle stay as they are.
io::Phase rows_to_owners(MPI_Comm comm, int ranks, const io::Phase& p,
                         const std::vector<int>& owner) {
  return per_particle_fields(p, [&](const io::Field& f) {
    const std::size_t row = std::size_t(f.components) * io::dtype_size(f.type);
    std::vector<std::vector<unsigned char>> to(static_cast<std::size_t>(ranks));
    for (std::size_t i = 0; i < f.count; ++i)
      to[owner[i]].insert(to[owner[i]].end(), f.bytes.begin() + i * row,
                          f.bytes.begin() + (i + 1) * row);
    io::Field g{f.name, f.type, f.components, 0, comm::exchange_bytes(comm, to)};
    g.count = row ? g.bytes.size() / row : 0;
    return g;
  });
}

} // namespace

template <typename T>
io::Frame SimulationT<T>::frame() const {
  io::Frame fr;
  fr.time = time_;
  fr.step = steps_;
  fr.scene_text = scene_.text;
  fr.scene_dir = scene_.files_dir;
  fr.precision = std::string(to_string(scene_.precision));
  // On N ranks the counters are the job's (each rank counts its own particles).
  const auto job = [this](double v) { return ranks_ ? ranks_->mpi().sum(v) : v; };
  fr.scalars.push_back({"guard_corrections", job(static_cast<double>(guard_corrections()))});
  if (sheet_guard_on_)
    fr.scalars.push_back({"sheet_corrections", job(static_cast<double>(sheet_corrections()))});
  fr.scalars.push_back({"outflow_particles", job(static_cast<double>(outflow_particles_))});
  fr.scalars.push_back({"outflow_mass", job(outflow_mass())});
  fr.scalars.push_back({"next_fluid_id", static_cast<double>(next_fluid_id_)});
  if (fluid_on_) {
    io::Phase p{"fluid", {}};
    p.fields.push_back(io::Field::from("position", flatten(fluid_->x.to_host()), 3));
    p.fields.push_back(io::Field::from("velocity", flatten(fluid_->v.to_host()), 3));
    p.fields.push_back(io::Field::from("acceleration", flatten(fluid_->a.to_host()), 3));
    p.fields.push_back(io::Field::from("mass", fluid_->m.to_host(), 1));
    p.fields.push_back(io::Field::from("density", fluid_->rho.to_host(), 1));
    p.fields.push_back(io::Field::from("pressure", fluid_->p.to_host(), 1));
    // Under continuity the density's rates are state the next step needs, like a.
    if (continuity()) {
      p.fields.push_back(io::Field::from("density_rate", fluid_->drho.to_host(), 1));
      p.fields.push_back(io::Field::from("density_rate_previous", fluid_->drho_prev.to_host(), 1));
    }
    p.fields.push_back(io::Field::from("id", fluid_->id.to_host(), 1));
    if (ranks_) { // which rank owns each particle (ParaView colours by it); ghosts not written
      keep_rows(p, fluid_owned_rows());
      p.fields.push_back(io::Field::from(
          "rank", std::vector<std::uint32_t>(p.fields[0].count, std::uint32_t(ranks_->rank())), 1));
    }
    // "verlet" lists: the positions they were built for and the rule's bounds since, so that a
    // restart lists and sorts the fluid when this run does (restore_fluid_grid). One rank only:
    // on N ranks each rank lists its ghosts too and builds at steps of its own (the local rule),
    // and a restart partitions anew and lists at its first step (restore).
    if (fluid_list_ && skin_ > 0 && !ranks_) {
      const auto st = fluid_list_->state();
      if (!st.x0.empty()) {
        p.fields.push_back(io::Field::from("listed_position", flatten(st.x0), 3));
        fr.scalars.push_back({"list_bound", static_cast<double>(st.bound)});
        fr.scalars.push_back({"list_pair_bound", static_cast<double>(st.pair)});
      }
    }
    fr.phases.push_back(std::move(p));
  }
  if (boundary_on_) {
    io::Phase p{"boundary", {}};
    p.fields.push_back(io::Field::from("position", flatten(boundary_->x.to_host()), 3));
    p.fields.push_back(io::Field::from("rest_position", flatten(boundary_->x0.to_host()), 3));
    p.fields.push_back(io::Field::from("volume", boundary_->volume.to_host(), 1));
    p.fields.push_back(io::Field::from("pressure", boundary_->p.to_host(), 1));
    p.fields.push_back(io::Field::from("obstacle", boundary_->obstacle.to_host(), 1));
    p.fields.push_back(io::Field::from("id", boundary_->id.to_host(), 1));
    if (ranks_) { // the ghosts are their owners' to write
      keep_rows(p, ranks_->boundary_owned());
      p.fields.push_back(io::Field::from(
          "rank", std::vector<std::uint32_t>(p.fields[0].count, std::uint32_t(ranks_->rank())), 1));
    }
    fr.phases.push_back(std::move(p));
  }
  if (knit_on_) {
    io::Phase kp = knit_->phase();
    std::vector<double> wet; // the knit's saturation, for the yarns
    const bool wets = coupling_ && scene_.has(Module::Capillary);
    if (wets) {
      std::vector<T> sat, held;
      if (absorption_) {
        held = absorption_->absorbed().to_host();
        const auto cap = absorption_->capacity().to_host();
        sat.resize(held.size());
        for (std::size_t i = 0; i < held.size(); ++i)
          sat[i] = held[i] / cap[i];
      } else {
        sat = coupling_->saturation().to_host();
        held = coupling_->fluid_mass().to_host();
      }
      sat.resize(knit_->owned()); // on N ranks the ghosts' follow
      held.resize(knit_->owned());
      wet.assign(sat.begin(), sat.end());
      kp.fields.push_back(io::Field::from("saturation", sat, 1));
      kp.fields.push_back(io::Field::from("fluid_mass", held, 1));
    }
    // The knit's grids kept over steps (self-collision, coupling): a restart sorts them when
    // this run does, so their sums keep this run's order.
    if (knit_halo_ && knit_->self_collision())
      put_watch<T>(fr, kp, "self_contact", knit_halo_->self_contact_state(), true);
    else if (const auto st = knit_->self_contact_state())
      put_watch<T>(fr, kp, "self_contact", *st);
    if (coupling_)
      put_watch<T>(fr, kp, "coupling",
                   knit_halo_ ? knit_halo_->coupling_state() : coupling_->state(),
                   knit_halo_.has_value());
    if (ranks_)
      kp.fields.push_back(io::Field::from(
          "rank", std::vector<std::uint32_t>(knit_->owned(), std::uint32_t(ranks_->rank())), 1));
    fr.phases.push_back(std::move(kp));
    if (scene_.knit.yarn_samples > 0) {
      if (knit_halo_) { // the yarns run through points of every rank: rank 0 writes them all
        const auto all = knit_halo_->positions_on_root();
        const auto wet_all = wets ? knit_halo_->values_on_root(wet) : wet; // collective
        fr.phases.push_back(knit_->yarn_phase(wets ? &wet_all : nullptr, &all));
      } else {
        fr.phases.push_back(knit_->yarn_phase(wet.empty() ? nullptr : &wet));
      }
    }
  }
  return fr;
}

template <typename T>
void SimulationT<T>::restore(const io::Frame& fr) {
  fluid_bounds_ready_ = false;
  // On N ranks every rank reads the whole frame, whatever rank count wrote it, and keeps what
  // it owns (below); the job's counters are taken once, on rank 0.
  const bool counters = !ranks_ || ranks_->rank() == 0;
  if (fr.precision != to_string(scene_.precision))
    throw Error("restart: the snapshot holds " + fr.precision + " data but the scene asks for " +
                std::string(to_string(scene_.precision)));
  time_ = fr.time;
  steps_ = fr.step;
  for (const auto& [k, v] : fr.scalars)
    if (k == "guard_corrections")
      guard_count_.assign(std::vector<std::uint64_t>{counters ? static_cast<std::uint64_t>(v) : 0});
    else if (k == "sheet_corrections") {
      if (sheet_guard_on_)
        sheet_count_.assign(
            std::vector<std::uint64_t>{counters ? static_cast<std::uint64_t>(v) : 0});
    } else if (k == "outflow_particles")
      outflow_particles_ = counters ? static_cast<std::uint64_t>(v) : 0;
    else if (k == "outflow_mass") {
      outflow_mass_ = counters ? v : 0.0;
      sorted_outflow_mass_.assign(std::vector<double>{0.0});
    } else if (k == "next_fluid_id")
      next_fluid_id_ = static_cast<std::uint64_t>(v);
  update_shapes(time_);
  const io::Phase* fluid_phase = fluid_on_ ? fr.find("fluid") : nullptr;
  const io::Phase* boundary_phase = boundary_on_ ? fr.find("boundary") : nullptr;
  if (fluid_on_ && !fluid_phase)
    throw Error("restart: the snapshot has no fluid phase but the scene has fluid");
  if (boundary_on_ && !boundary_phase)
    throw Error("restart: the snapshot has no boundary phase but the scene has one");
  std::optional<io::Phase> knit_phase;
  if (knit_on_) {
    const io::Phase* p = fr.find("knit");
    if (!p)
      throw Error("restart: the snapshot has no knit phase but the scene has knit");
    knit_phase = *p;
    rows_by_id(*knit_phase); // in mesh order, whatever rank count wrote it
  }
  // On N ranks the blocks are partitioned anew from the frame's particles (the results do not
  // depend on the partition), as every rank does alike, and only this rank's fluid and boundary
  // go to the backend; the knit is shared out by KnitHalo. A frame read whole on every rank
  // (tests) keeps each rank's rows of it; one read in shares (a run's restart: no host holds the
  // whole frame) combines the shares' box and counts over the ranks and sends each row to its
  // owner.
  // Shares are a rank's part of the file only among the ranks that read them.
  if ((fr.shared("fluid") || fr.shared("boundary")) &&
      fr.share_ranks != (ranks_ ? ranks_->ranks() : 1))
    throw Error("restart: the frame was read in shares over " + std::to_string(fr.share_ranks) +
                " ranks, the simulation runs on " + std::to_string(ranks_ ? ranks_->ranks() : 1));
  std::optional<Decomposition> split;
  io::Phase fluid_mine, boundary_mine;
  if (ranks_) {
    const auto positions = [](const io::Phase* p) {
      return p ? unflatten(require(*p, "position").as<T>()) : std::vector<Vec3<T>>{};
    };
    const auto fx = positions(fluid_phase), bx = positions(boundary_phase),
               kx = positions(knit_phase ? &*knit_phase : nullptr);
    const bool fluid_shared = fluid_phase && fr.shared("fluid");
    const bool boundary_shared = boundary_phase && fr.shared("boundary");
    const bool shares = fluid_shared || boundary_shared;
    // With shares, a phase every rank holds whole counts on rank 0 alone (the counts are summed).
    const auto source = [&](const std::vector<Vec3<T>>& x, bool shared) -> PointSource<T> {
      const bool counted = !shares || shared || ranks_->rank() == 0;
      return [&x, counted](const std::function<void(const Vec3<T>&)>& f) {
        if (counted)
          for (const auto& q : x)
            f(q);
      };
    };
    const PointShares over = shares ? point_shares(ranks_->mpi()) : PointShares{};
    split.emplace(first_partition<T>(
        scene_, ranks_->widths(), ranks_->phase_costs(), ranks_->ranks(),
        {source(fx, fluid_shared), source(bx, boundary_shared), source(kx, false)}, over));
    const auto keep = [&](const io::Phase& p, const std::vector<Vec3<T>>& x, bool shared) {
      if (!shared)
        return rows_kept(p, owned_rows<T>(*split, ranks_->rank(), x));
      std::vector<int> owner(x.size());
      for (std::size_t i = 0; i < x.size(); ++i)
        owner[i] = owner_of(*split, x[i]);
      return rows_to_owners(ranks_->mpi().comm(), ranks_->ranks(), p, owner);
    };
    if (fluid_phase)
      fluid_phase = &(fluid_mine = keep(*fluid_phase, fx, fluid_shared));
    if (boundary_phase)
      boundary_phase = &(boundary_mine = keep(*boundary_phase, bx, boundary_shared));
  }
  if (fluid_on_) {
    const io::Phase* p = fluid_phase;
    const auto x = unflatten(require(*p, "position").as<T>());
    fluid_->resize(x.size());
    fluid_->x.assign(x);
    fluid_->v.assign(unflatten(require(*p, "velocity").as<T>()));
    fluid_->a.assign(unflatten(require(*p, "acceleration").as<T>()));
    fluid_->m.assign(require(*p, "mass").as<T>());
    fluid_->rho.assign(require(*p, "density").as<T>());
    fluid_->p.assign(require(*p, "pressure").as<T>());
    if (continuity()) {
      const io::Field* r = p->find("density_rate");
      if (!r)
        throw Error("restart: the snapshot's fluid has no density_rate but the scene integrates "
                    "the density (solver.density = \"continuity\"); it was written with "
                    "\"summation\"");
      fluid_->drho.assign(r->as<T>());
      fluid_->drho_prev.assign(require(*p, "density_rate_previous").as<T>());
    } else {
      fluid_->drho.assign(std::vector<T>(x.size(), T(0)));
      fluid_->drho_prev.assign(std::vector<T>(x.size(), T(0)));
    }
    fluid_->id.assign(require(*p, "id").as<std::uint64_t>());
  }
  if (boundary_on_) {
    const io::Phase* p = boundary_phase;
    const auto x = unflatten(require(*p, "position").as<T>());
    boundary_->resize(x.size());
    boundary_->x.assign(x);
    boundary_->x0.assign(unflatten(require(*p, "rest_position").as<T>()));
    boundary_->obstacle.assign(require(*p, "obstacle").as<std::uint32_t>());
    boundary_->volume.assign(require(*p, "volume").as<T>());
    boundary_->id.assign(require(*p, "id").as<std::uint64_t>());
    // Same order as when written, so the grid comes out identical.
    if (!ranks_)
      sort_boundary();
  }
  if (knit_on_) {
    knit_->restore(*knit_phase);
    if (absorption_) { // the whole knit's, before N ranks share the points out again
      const io::Field* a = knit_phase->find("fluid_mass");
      if (!a)
        throw Error("restart: the snapshot's knit has no fluid_mass but the scene absorbs fluid "
                    "(capillary.model = \"conserving\")");
      absorption_->restore(ex_, knit_->set(), a->as<T>());
    }
  }
  if (ranks_) {
    // Each rank holds its share (above); the next step's sort rebuilds the rest.
    ranks_->adopt(std::move(*split), fluid_on_ ? &*fluid_ : nullptr,
                  boundary_on_ ? &*boundary_ : nullptr, steps_);
    if (fluid_list_) // "verlet" lists: built at the next step for the positions then
      fluid_list_->forget();
    fit_grids_to_region();
    if (boundary_on_)
      sort_boundary();
    if (knit_halo_) {
      // The grids' reference positions travel with the points; without them (an older
      // snapshot) the positions now.
      const auto watch = [&](bool on, const char* name) {
        const auto st = on ? get_watch<T>(fr, *knit_phase, name) : std::nullopt;
        return st ? *st : typename SkinWatch<T>::State{{}, T(0), T(0)};
      };
      knit_halo_->distribute(watch(knit_->self_collision(), "self_contact"),
                             watch(coupling_.has_value(), "coupling"));
    }
    if (coupling_on_) {
      // The coupling reads the fluid around each knit point before the next drift: the ghosts
      // and the grid now, for the same positions as the run that wrote the frame sorted them.
      sort_fluid(false, {true});
      ranks_->refresh_motion(*fluid_);
      update_saturation();
    }
    return;
  }
  if (knit_on_) {
    const io::Phase* p = &*knit_phase;
    // Without their state (an older snapshot) the grids stay as built for the scene's start:
    // correct (their watches measure from there), but not sorted when the run it continues
    // sorted them, so rounding may differ.
    if (knit_->self_collision())
      if (const auto st = get_watch<T>(fr, *p, "self_contact"))
        knit_->restore_self_contact(*st);
    if (coupling_)
      if (const auto st = get_watch<T>(fr, *p, "coupling"))
        coupling_->restore(ex_, knit_->set(), *st);
  }
  if (fluid_on_)
    restore_fluid_grid(fr);
  if (coupling_on_)
    update_saturation();
}

template <typename T>
void SimulationT<T>::restore_fluid_grid(const io::Frame& fr) {
  // The stages before a step's sort walk the fluid's grid (absorption, the coupling), and
  // "verlet" lists keep it over steps: the grid must be the one the uninterrupted run holds,
  // not the scene's first. The snapshot's fluid is in the order of that run's last sort, for
  // the positions it had then: the positions now (walk, or "on": sorted every step after the
  // drift), or those the lists were built for ("verlet", written with them). The sort is
  // stable, so sorting for the same positions again keeps the order (the identity permutation;
  // any other is applied to the fields the sort does not carry) and rebuilds the grid, the
  // flags of the cells near fluid and the lists bit for bit. The rule's bounds since that build
  // are restored too, so the lists are built again at the step the run built them.
  const std::vector<Vec3<T>> x = fluid_->x.to_host();
  const std::vector<Vec3<T>> a = fluid_->a.to_host();
  const std::vector<T> pressure = fluid_->p.to_host();
  std::optional<typename SphLists<T>::State> listed;
  if (fluid_list_ && skin_ > 0) {
    const io::Field* x0 = fr.find("fluid")->find("listed_position");
    const double* bound = find_scalar(fr, "list_bound");
    const double* pair = find_scalar(fr, "list_pair_bound");
    if (x0 && bound && pair) {
      listed = {unflatten(x0->as<T>()), static_cast<T>(*bound), static_cast<T>(*pair)};
      if (listed->x0.size() != x.size())
        throw Error("restart: the snapshot lists " + std::to_string(listed->x0.size()) +
                    " fluid particles but holds " + std::to_string(x.size()));
      fluid_->x.assign(listed->x0);
    }
    // Else (an older snapshot) the lists are built for the positions now: correct, but the
    // run it continues kept older lists, so rounding may differ.
  }
  sort_fluid(false, {false, false}); // a and p: put back below
  if (fluid_list_)
    fluid_list_->settle(ex_); // before anything rewrites the positions it listed
  const std::vector<std::uint32_t> perm = fluid_grid_->permutation().to_host();
  if (listed) {
    fluid_->x.assign(permuted(x, perm));
    fluid_list_->restore(*listed);
  }
  fluid_->a.assign(permuted(a, perm));
  fluid_->p.assign(permuted(pressure, perm));
}

template io::Frame SimulationT<float>::frame() const;
template void SimulationT<float>::restore(const io::Frame&);
template void SimulationT<float>::restore_fluid_grid(const io::Frame&);
template io::Frame SimulationT<double>::frame() const;
template void SimulationT<double>::restore(const io::Frame&);
template void SimulationT<double>::restore_fluid_grid(const io::Frame&);

} // namespace kf
