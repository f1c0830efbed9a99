(function () {
  function sortValue(cell) {
    var text = cell.hasAttribute('data-sort') ? cell.getAttribute('data-sort') : cell.textContent.trim();
    var number = Number(text);
    if (text === '') return {empty: true};
    return isNaN(number) ? {text: text.toLowerCase()} : {number: number};
  }
  function compare(a, b) {
    if (a.empty || b.empty) return (a.empty ? 1 : 0) - (b.empty ? 1 : 0);
    if ('number' in a && 'number' in b) return a.number - b.number;
    var x = 'number' in a ? String(a.number) : a.text, y = 'number' in b ? String(b.number) : b.text;
    return x < y ? -1 : x > y ? 1 : 0;
  }
  function sortBy(table, column, header) {
    var descending = header.getAttribute('aria-sort') === 'ascending';
    Array.prototype.forEach.call(table.tHead.rows[0].cells, function (th) { th.setAttribute('aria-sort', 'none'); });
    header.setAttribute('aria-sort', descending ? 'descending' : 'ascending');
    var body = table.tBodies[0];
    var rows = Array.prototype.slice.call(body.rows).map(function (row) {
      return {row: row, value: sortValue(row.cells[column])};
    });
    rows.sort(function (a, b) {
      if (a.value.empty || b.value.empty) return compare(a.value, b.value);
      return descending ? compare(b.value, a.value) : compare(a.value, b.value);
    });
    rows.forEach(function (item) { body.appendChild(item.row); });
  }
  Array.prototype.forEach.call(document.querySelectorAll('table.sortable'), function (table) {
    Array.prototype.forEach.call(table.tHead.rows[0].cells, function (header, column) {
      header.tabIndex = 0;
      header.title = 'sort by this column (click again to reverse)';
      header.addEventListener('click', function () { sortBy(table, column, header); });
      header.addEventListener('keydown', function (event) {
        if (event.key === 'Enter' || event.key === ' ') { event.preventDefault(); sortBy(table, column, header); }
      });
    });
  });
})();
